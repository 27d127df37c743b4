"""The tools against a real graph: one `robot-controller run` shared by
the module, each tool in a process of its own, as a user would run it.

Fast DDS reads its XML profile once per process, so the tools cannot run in
this one. The run puts its loop topics in a partition of its own and the tools'
processes get no profile from us: that they hear /joint_states at all is the
observer profile they write for themselves."""

import os
import re
import signal
import subprocess
import sys
import threading
import time

import pytest
import yaml

from robot_controller.ros import partition

pytestmark = pytest.mark.ros

# Apart from conftest's 1..100, spread over concurrent sessions by process id.
DOMAIN = 150 + os.getpid() % 50


def tool_env() -> dict[str, str]:
    env = dict(os.environ)
    env.pop(partition.PROFILES_ENV, None)  # neither the run nor the tools are handed a profile
    env.pop("ROS_AUTOMATIC_DISCOVERY_RANGE", None)  # the tools keep discovery on this host themselves
    env["ROS_DOMAIN_ID"] = str(DOMAIN)
    return env


def tool(code: str, timeout: float = 15) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh interpreter with ``topic``, ``param``, ``graph`` and ``sys`` imported.
    (The slowest, hz for 3.5 s, takes 5; an echo that hears nothing would wait for ever.)"""
    script = "import sys\nfrom robot_controller.tools import graph, param, topic\n" + code
    return subprocess.run(
        [sys.executable, "-c", script], env=tool_env(), capture_output=True, text=True, timeout=timeout
    )


def one_error_line(done: subprocess.CompletedProcess) -> str:
    assert done.returncode == 1, done.stdout + done.stderr
    assert done.stdout == ""
    assert "Traceback" not in done.stderr
    lines = done.stderr.splitlines()
    assert len(lines) == 1, done.stderr
    return lines[0]


# --- without the run ----------------------------------------------------------


def test_a_topic_that_is_not_there_is_one_line_on_stderr_and_exit_1():
    done = tool("topic.TOPIC_WAIT_S = 1.0\nsys.exit(topic.topic_echo('/nope', 3, False))")
    assert one_error_line(done) == f"robot-controller topic echo: /nope: no such topic on domain {DOMAIN}"


def test_a_node_that_does_not_answer_is_one_line_on_stderr_and_exit_1():
    done = tool("graph.DISCOVERY_TIMEOUT_S = 1.0\nsys.exit(param.param_get('nobody', 'kp'))")
    line = one_error_line(done)
    assert line.startswith("robot-controller param get: /nobody: ") and f"domain {DOMAIN}" in line, line


def test_the_tools_hear_every_partition_through_a_profile_of_their_own_that_they_leave_nowhere():
    done = tool(
        "import os\nfrom robot_controller.ros import partition\n"
        "seen = {}\nwrite = partition.write_observer_profile\n"
        "def spy(path, base=None, **options):\n"
        "    seen['path'] = path\n"
        "    seen['text'] = write(path, base, **options).read_text()\n"
        "    return path\n"
        "partition.write_observer_profile = spy\n"
        "with graph.open_graph('check') as g:\n"
        "    assert os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'LOCALHOST'\n"
        "    assert partition.PROFILES_ENV not in os.environ, 'a child process would inherit a path that is gone'\n"
        "    assert not seen['path'].parent.exists()\n"
        "    assert g.domain == int(os.environ['ROS_DOMAIN_ID'])\n"
        "with graph.open_graph('again'):\n"
        "    pass\n"
        "print(seen['text'])\n"
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert "<name>partitions</name>" in done.stdout and "<value>;*</value>" in done.stdout  # every partition, read
    # On this host: UDP on loopback, no shared memory (a loop process must never wait on a tool's).
    assert "<useBuiltinTransports>false</useBuiltinTransports>" in done.stdout and "<type>UDPv4</type>" in done.stdout
    assert "<address>127.0.0.1</address>" in done.stdout


# --- against the run ------------------------------------------------------------


@pytest.fixture(scope="module")
def running_graph(tmp_path_factory):
    """A run on DOMAIN, its loop running, long enough for the module's tests on a busy host (they take about 20 s
    on a quiet one); interrupted (Ctrl-C) once the module is done."""
    out = tmp_path_factory.mktemp("tools") / "run"
    run = subprocess.Popen(
        [sys.executable, "-m", "robot_controller.cli", "run", "--duration", "300", "--out", str(out)],
        env=tool_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    output: list[str] = []
    deadline = time.monotonic() + 60
    for line in run.stdout:
        output.append(line)
        if "control loop running" in line:
            break
        assert time.monotonic() < deadline, "the loop did not start"
    else:
        raise AssertionError("the run ended before its loop started:\n" + "".join(output)[-3000:])
    drain = threading.Thread(target=lambda: output.extend(run.stdout), daemon=True)  # its pipe must not fill up
    drain.start()
    try:
        yield run
    finally:
        if run.poll() is None:
            run.send_signal(signal.SIGINT)
            try:
                run.wait(timeout=60)
            except subprocess.TimeoutExpired:
                run.kill()
                run.wait()


def alive(run: subprocess.Popen) -> None:
    assert run.poll() is None, "the run ended before this test"


def test_topic_list_shows_the_loop_topics_and_their_types(running_graph):
    alive(running_graph)
    plain, typed = tool("sys.exit(topic.topic_list())"), tool("sys.exit(topic.topic_list(show_types=True))")
    assert plain.returncode == 0 and typed.returncode == 0, plain.stderr + typed.stderr
    names = plain.stdout.splitlines()
    assert "/joint_states" in names and "/joint_commands" in names, plain.stdout
    assert names == sorted(names)
    assert "/joint_states [sensor_msgs/msg/JointState]" in typed.stdout.splitlines(), typed.stdout


def test_echo_prints_exactly_count_messages_as_yaml_each_followed_by_dashes(running_graph):
    alive(running_graph)
    done = tool("sys.exit(topic.topic_echo('/joint_commands', 3, False))")
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.endswith("---\n")
    messages = done.stdout.split("---\n")[:-1]
    assert len(messages) == 3, done.stdout
    for text in messages:
        assert re.search(r"^data:$", text, re.M), text
        message = yaml.safe_load(text)
        assert set(message) == {"layout", "data"}
        assert len(message["data"]) == 1 and isinstance(message["data"][0], float)


def test_echo_of_a_partitioned_loop_topic_indents_its_nested_fields(running_graph):
    alive(running_graph)
    done = tool("sys.exit(topic.topic_echo('joint_states', 1, False))")  # a relative name, as ros2 takes it
    assert done.returncode == 0, done.stderr[-3000:]
    assert re.match(
        r"header:\n  stamp:\n    sec: \d+\n    nanosec: \d+\n  frame_id: ''\nname:\n- joint1\n" r"position:\n- \S+\n",
        done.stdout,
    ), done.stdout
    assert done.stdout.count("---\n") == 1


def test_echo_csv_prints_a_header_then_one_line_of_numbers_per_message(running_graph):
    alive(running_graph)
    done = tool("sys.exit(topic.topic_echo('/joint_commands', 3, True))")
    assert done.returncode == 0, done.stderr[-3000:]
    header, *lines = done.stdout.splitlines()
    assert header == "layout.dim[0].label,layout.dim[0].size,layout.dim[0].stride,layout.data_offset,data[0]"
    assert len(lines) == 3, done.stdout
    for line in lines:
        assert len(line.split(",")) == len(header.split(","))
        cells = line.split(",")
        assert cells[0].startswith("tick_ns:")  # layout.dim[0]: the label carries the command's tick
        assert [float(cell) for cell in cells[1:]]  # its size and stride, data_offset, then the torque


def test_hz_reports_the_sensor_rate_every_second_in_ros2_s_format(running_graph):
    alive(running_graph)
    done = tool("sys.exit(topic.topic_hz('/joint_states', 10000, 3.5))")
    assert done.returncode == 0, done.stderr[-3000:]
    rates = [float(x) for x in re.findall(r"^average rate: (\d+\.\d{3})$", done.stdout, re.M)]
    details = re.findall(r"^\tmin: \d+\.\d{3}s max: \d+\.\d{3}s std dev: \d+\.\d{5}s window: (\d+)$", done.stdout, re.M)
    assert len(rates) >= 2 and len(details) == len(rates), done.stdout
    assert 80 <= rates[-1] <= 120, done.stdout  # 100 Hz on a quiet machine; this one is shared
    assert int(details[-1]) > rates[-1]  # over a second of intervals (about 3 s on a quiet machine)


def test_param_set_kp_then_get_shows_a_double_array(running_graph):
    alive(running_graph)
    done = tool("sys.exit(param.param_set('pid_controller', 'kp', '60'))")
    assert (done.returncode, done.stdout, done.stderr) == (0, "Set parameter successful\n", "")
    done = tool("sys.exit(param.param_get('/pid_controller', 'kp'))")
    assert (done.returncode, done.stdout) == (0, "Double array value is: [60.0]\n"), done.stderr


def test_param_set_of_a_value_the_node_refuses_prints_its_reason_and_exits_1(running_graph):
    alive(running_graph)
    done = tool("sys.exit(param.param_set('pid_controller', 'kp', '-1'))")
    assert done.returncode == 1, done.stdout + done.stderr
    assert done.stderr.startswith("Setting parameter failed: ") and "kp: must be >= 0" in done.stderr, done.stderr
    assert done.stdout == ""


def test_param_set_of_a_safety_setting_is_refused_with_the_reason_and_the_old_value_stays(running_graph):
    alive(running_graph)
    done = tool("sys.exit(param.param_set('motor_node', 'command_timeout_s', '10'))")
    reason = "command_timeout_s: safety setting: set it in the run's config, not at run time"
    assert one_error_line(done) == f"Setting parameter failed: {reason}"
    done = tool("sys.exit(param.param_get('motor_node', 'command_timeout_s'))")
    assert (done.returncode, done.stdout) == (0, "Double value is: 0.05\n"), done.stderr


def test_param_set_of_a_parameter_the_node_lacks_names_it_and_the_close_ones(running_graph):
    alive(running_graph)
    done = tool("sys.exit(param.param_set('pid_controller', 'kpp', '60'))")
    assert done.returncode == 1, done.stdout + done.stderr
    (line,) = done.stderr.strip().splitlines()
    assert line.startswith("Setting parameter failed: /pid_controller has no parameter kpp (did you mean kp"), line


def test_param_get_labels_each_type_as_ros2_does_several_calls_in_one_process(running_graph):
    alive(running_graph)
    done = tool(
        "for name in ('controller_type', 'control_rate_hz', 'watchdog_periods', 'reference_extrapolation'):\n"
        "    assert param.param_get('pid_controller', name) == 0\n"
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.splitlines() == [
        "String value is: lqr",
        "Double value is: 100.0",
        "Integer value is: 5",
        "Boolean value is: True",
    ]


def test_param_list_and_dump_show_every_parameter(running_graph):
    alive(running_graph)
    listed = tool("sys.exit(param.param_list('pid_controller'))")
    dumped = tool("sys.exit(param.param_dump('pid_controller'))")
    assert listed.returncode == 0 and dumped.returncode == 0, listed.stderr + dumped.stderr
    names = [line.strip() for line in listed.stdout.splitlines()]
    assert all(line.startswith("  ") for line in listed.stdout.splitlines())
    assert "kp" in names and "controller_type" in names and names == sorted(names)
    assert "ros__parameters" in dumped.stdout
    values = yaml.safe_load(dumped.stdout)["/pid_controller"]["ros__parameters"]
    assert sorted(values) == names
    assert values["controller_type"] == "lqr" and values["control_rate_hz"] == 100.0
