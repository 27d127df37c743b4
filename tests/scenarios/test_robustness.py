"""Bad input never stops the loop; the watchdog; live parameters; the launcher cleans up.

Real nodes in real processes on their own ROS_DOMAIN_ID; the test talks to
them over DDS like any other node would.
"""

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from rcl_interfaces.msg import ParameterType, ParameterValue
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from robot_controller import parameters as cfg
from tests.rostools import RosProbe, run_said, set_parameter, wait_for

pytestmark = pytest.mark.ros


def stop_node(process):
    """SIGINT, and the output; a node that does not exit in 15 s is killed and fails the test."""
    process.send_signal(signal.SIGINT)
    try:
        return process.communicate(timeout=15)[0]
    except subprocess.TimeoutExpired:
        process.kill()
        process.communicate()
        raise AssertionError("the node did not exit within 15 s of SIGINT") from None


def start_node(name, params_file, env=None):
    return subprocess.Popen(
        [sys.executable, "-m", f"robot_controller.nodes.{name}", "--ros-args", "--params-file", str(params_file)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env,
    )


def joint_state(names, position, velocity, stamp_ns=None):
    msg = JointState()
    if stamp_ns is not None:
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
    msg.name, msg.position, msg.velocity = names, position, velocity
    return msg


def test_malformed_messages_are_dropped_and_the_watchdog_zeroes_torque(tmp_path, ros_domain):
    params_file = cfg.write_params_file(cfg.load_stack(), tmp_path / "params.yaml")
    controller = start_node("pid_controller", params_file)
    probe = RosProbe(ros_domain)
    try:
        commands = probe.collect(Float64MultiArray, "/joint_commands")
        states = probe.node.create_publisher(JointState, "/joint_states", 10)
        trajectory = probe.node.create_publisher(Float64MultiArray, "/trajectory", 10)
        clock = probe.node.get_clock()
        nan, inf = float("nan"), float("inf")
        malformed_states = [
            ([], [], []),
            (["joint1"], [], []),
            (["joint1"], [0.1, 0.2], [0.0]),
            (["joint1"], [nan], [0.0]),
            (["joint1"], [0.0], [inf]),
            (["elbow"], [0.1], [0.0]),
            (["joint1", "joint2"], [0.1, 0.2], [0.0, 0.0]),
        ]
        malformed_trajectories = [[], [0.1], [0.1, 0.2, 0.3, 0.4], [nan, 0.0, 0.0], [1e308, inf, 0.0]]

        def good_state():
            states.publish(joint_state(["joint1"], [0.0], [0.0], clock.now().nanoseconds))

        # Prime with valid data, then interleave every malformed message for 2 s.
        wait_for(lambda: states.get_subscription_count() > 0, 20, "the controller to subscribe")
        end = time.monotonic() + 2.0
        k = 0
        while time.monotonic() < end:
            good_state()
            trajectory.publish(Float64MultiArray(data=[0.3, 0.0, 0.0]))
            states.publish(joint_state(*malformed_states[k % len(malformed_states)]))
            trajectory.publish(Float64MultiArray(data=malformed_trajectories[k % len(malformed_trajectories)]))
            k += 1
            time.sleep(0.01)
        assert controller.poll() is None, "the controller died on bad input"
        with probe.lock:
            received = [m.data.tolist() for _, m in commands]
        assert len(received) > 100
        assert all(len(u) == 1 and math.isfinite(u[0]) and abs(u[0]) <= 10.0 for u in received)
        assert any(abs(u[0]) > 1.0 for u in received[-50:]), "valid reference should drive a real torque"

        # Sensor stops: a controlled stop on the model (finite, bounded commands), then, 0.1 s
        # after it is at rest (at most sensor_timeout_s, 1 s), no more commands: the motor's
        # timeout brings the brake.
        # Heard as the probe hears them: a busy host may hold up the controller or the probe a while, so the stop
        # is waited for, not timed.
        sensor_stopped = time.monotonic()

        def since(start_s):
            with probe.lock:
                return [(t, m.data.tolist()[0]) for t, m in commands if t > start_s]

        wait_for(lambda: since(sensor_stopped), 5.0, "a command after the sensor stopped")
        wait_for(lambda: not since(time.monotonic() - 0.4), 10.0, "the commands to end")
        stopping = [u for _, u in since(sensor_stopped)]
        assert all(math.isfinite(u) and abs(u) <= 10.0 for u in stopping), stopping

        # ... and control resumes when data returns.
        for _ in range(30):
            good_state()
            time.sleep(0.01)
        with probe.lock:
            resumed = [m.data.tolist()[0] for t, m in commands if t > time.monotonic() - 0.1]
        assert any(u != 0.0 for u in resumed)
    finally:
        probe.close()
        output = stop_node(controller)
    assert controller.returncode == 0, run_said(output)
    assert "/joint_states dropped: " in output and "/trajectory dropped: " in output
    assert "controlled stop" in output and "no more commands" in output


def _set(probe, name, value):
    return set_parameter(probe, "pid_controller", name, value)


def test_gains_change_live_and_bad_values_are_refused(tmp_path, ros_domain):
    params_file = cfg.write_params_file(cfg.load_stack(), tmp_path / "params.yaml")
    controller = start_node("pid_controller", params_file)
    probe = RosProbe(ros_domain)
    try:
        double = lambda v: ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=v)  # noqa: E731
        ok = _set(probe, "kp", double(60.0))
        assert ok.successful, ok.reason
        ok = _set(probe, "kd", ParameterValue(type=ParameterType.PARAMETER_DOUBLE_ARRAY, double_array_value=[3.0]))
        assert ok.successful, ok.reason
        for name, value, reason in [
            ("kp", double(-1.0), "kp: must be >= 0"),
            ("ki", double(float("nan")), "ki: must be finite"),
            ("kd", ParameterValue(type=ParameterType.PARAMETER_STRING, string_value="high"), "kd: expected a number"),
            (
                "anti_windup",
                ParameterValue(type=ParameterType.PARAMETER_STRING, string_value="off"),
                "anti_windup: 'off' is not one of",
            ),
            (
                "kp",
                ParameterValue(type=ParameterType.PARAMETER_DOUBLE_ARRAY, double_array_value=[1.0, 2.0]),
                "kp: expected 1 value",
            ),
        ]:
            result = _set(probe, name, value)
            assert not result.successful and reason in result.reason, (name, result.reason)
        assert controller.poll() is None
    finally:
        probe.close()
        output = stop_node(controller)
    assert "parameters changed: kp=60.0" in output


def _children_of(pid):
    out = subprocess.run(["pgrep", "-P", str(pid)], capture_output=True, text=True).stdout.split()
    return [int(p) for p in out]


def _cmdline(pid):
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except FileNotFoundError:
        return ""


def _alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"


def _start_launcher(out):
    launcher = subprocess.Popen(
        [sys.executable, "-m", "robot_controller.cli", "run", "--duration", "60", "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    deadline = time.monotonic() + 60
    for line in launcher.stdout:
        if "control loop running" in line:
            break
        assert time.monotonic() < deadline, "the loop did not start"
    children = _children_of(launcher.pid)
    assert len(children) == 6, [(_cmdline(p)) for p in children]  # five nodes and the recorder
    return launcher, children


def _finish(launcher):
    try:
        return launcher.communicate(timeout=30)[0]
    except subprocess.TimeoutExpired:
        launcher.send_signal(signal.SIGUSR1)  # faulthandler: where each of its threads is
        time.sleep(1.0)
        launcher.kill()
        output = launcher.communicate()[0]
        raise AssertionError("the launcher did not exit within 30 s; it printed:\n" + output[-8000:]) from None


def test_a_crashing_node_ends_the_run_with_an_error_and_no_orphans(tmp_path, ros_domain):
    launcher, children = _start_launcher(tmp_path / "run")
    controller = next(p for p in children if "nodes.pid_controller" in _cmdline(p))
    os.kill(controller, signal.SIGKILL)
    output = _finish(launcher)
    assert launcher.returncode != 0
    assert "node died: pid_controller" in output
    wait_for(lambda: not any(_alive(p) for p in children), 10, "every child to exit")


def test_ctrl_c_stops_everything_cleanly_and_still_scores(tmp_path, ros_domain):
    launcher, children = _start_launcher(tmp_path / "run")
    time.sleep(3.0)
    launcher.send_signal(signal.SIGINT)
    output = _finish(launcher)
    assert launcher.returncode == 0, run_said(output)
    assert not any(_alive(p) for p in children)
    assert json.loads((tmp_path / "run" / "metrics.json").read_text())["control_ticks"] > 100
