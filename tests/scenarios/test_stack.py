"""The real multi-process graph: five nodes over DDS, recorded and scored.

Each test runs the project's own command on its own ROS_DOMAIN_ID.
"""

import json
import os
import re
import subprocess
import sys

import pytest
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore

from tests.hardware.stand_in import SLOW_TICK_P99_MS, stand_in_venv
from tests.rostools import run_said

pytestmark = pytest.mark.ros

EXPECTED_TOPICS = {
    "/trajectory": ("std_msgs/msg/Float64MultiArray", 100.0),
    "/joint_states": ("sensor_msgs/msg/JointState", 100.0),
    "/joint_commands": ("std_msgs/msg/Float64MultiArray", 100.0),
    "/sim/effort": ("std_msgs/msg/Float64MultiArray", 100.0),
    "/sim/joint_states": ("sensor_msgs/msg/JointState", 100.0),
    "/controller/state": ("std_msgs/msg/Float64MultiArray", 100.0),
}
# The tutorial's log line, under the node's name (process prefix or, in one process, the logger name).
LOG_LINE = re.compile(
    r"\[pid_controller\].* target=-?\d+\.\d{3}, actual=-?\d+\.\d{3}, " r"error=-?\d+\.\d{3}, torque=-?\d+\.\d{3}$",
    re.MULTILINE,
)


def run_cli(out, *extra, duration=6.0):
    return subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", "run", "--duration", str(duration), "--out", str(out), *extra],
        capture_output=True,
        text=True,
        timeout=150,
    )


@pytest.mark.parametrize("mode", ["multi_process", "single_process"])
def test_stack_runs_records_and_tracks(tmp_path, ros_domain, mode):
    """On the wall clock (``--wall-clock``), with its loop-health report; the paced world's is test_paced_world."""
    out = tmp_path / "run"
    proc = run_cli(out, "--wall-clock", *(["--single-process"] if mode == "single_process" else []))
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["mode"] == mode
    assert 90 < metrics["control_rate_hz"] < 110
    # On the wall clock a host's stall is the loop's fault by design (the drive refuses late commands): judged
    # against what the host did. Beside a CPU hog once 21.8 mrad, in 1 of 3 suites; 16 runs since: 1.2 mrad.
    health = ("tracking_max_rad", "missed_cycles", "missed_cycles_host", "watchdog_ticks", "brake_engagements")
    limit = 0.05 if metrics.get("missed_cycles_host", 0) else 0.02
    assert metrics["tracking_rms_rad"] < limit, ({key: metrics.get(key) for key in health}, run_said(proc.stdout))
    assert metrics["tracking_rms_rad"] <= metrics["tracking_max_rad"]
    assert metrics["peak_torque_nm"] <= 10.0
    for topic, (_, rate) in EXPECTED_TOPICS.items():
        key = topic.strip("/").replace("/", "_")
        assert 0.7 * rate < metrics[f"rate_{key}_hz"] < 1.3 * rate, topic
    assert (out / "tracking.png").stat().st_size > 10_000
    assert LOG_LINE.search(proc.stdout), proc.stdout[-2000:]

    assert "storage_identifier: mcap" in (out / "bag" / "metadata.yaml").read_text()
    assert list((out / "bag").glob("*.mcap"))
    with Reader(out / "bag") as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
        counts = {c.topic: c.msgcount for c in reader.connections}
    for topic, (msgtype, rate) in EXPECTED_TOPICS.items():
        assert types[topic] == msgtype
        assert counts[topic] > 0.5 * rate * 6.0, topic

    # Loop health, once a second on /diagnostics.
    typestore = get_typestore(Stores.ROS2_JAZZY)
    with Reader(out / "bag") as reader:
        reports = [
            typestore.deserialize_cdr(raw, c.msgtype) for c, _, raw in reader.messages() if c.topic == "/diagnostics"
        ]
    assert len(reports) >= 4
    # The last report with a window of ticks (on a busy host the last second before the stop can have none).
    reported = [{kv.key: float(kv.value) for kv in report.status[0].values} for report in reports]
    values = next(v for v in reversed(reported) if v.get("ticks", 1) > 0)
    for key in (
        "control_rate_hz",
        "jitter_p50_ms",
        "jitter_p99_ms",
        "jitter_max_ms",
        "missed_cycles",
        "latency_p50_ms",
        "latency_p99_ms",
    ):
        assert key in values, key
    assert 80 < values["control_rate_hz"] < 120
    for key in ("latency_p50_ms", "latency_p99_ms", "jitter_p99_ms", "missed_cycles"):
        assert key in metrics, key


def test_tutorial_preset_runs_and_lags(tmp_path, ros_domain):
    out = tmp_path / "tutorial"
    proc = run_cli(out, "--preset", "tutorial", duration=5.0)
    # It lags the sine by about 0.2 rad: a run that does not track is never ok.
    assert proc.returncode == 1, run_said(proc.stdout)
    assert proc.stdout.splitlines()[-1].startswith("FAILED: tracking "), run_said(proc.stdout)
    assert "beyond its 20 mrad tracking band" in proc.stdout
    assert "the tutorial claims ~5 mrad" in proc.stdout
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["verdict"] == "failed" and metrics["tracking_band_rad"] == 0.02
    assert metrics["preset"] == "tutorial"
    assert 0.1 < metrics["tracking_rms_rad"] < 0.4
    assert 15 < metrics["rate_trajectory_hz"] < 25


def test_rescoring_a_saved_run_gives_the_same_figures(tmp_path, ros_domain):
    out = tmp_path / "run"
    assert run_cli(out, duration=4.0).returncode == 0
    saved = json.loads((out / "metrics.json").read_text())
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", "score", str(out), "--json"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 0
    rescored = json.loads(proc.stdout)
    assert rescored["tracking_rms_rad"] == saved["tracking_rms_rad"]


def test_the_bag_holds_every_message_the_nodes_published(tmp_path, ros_domain):
    out = tmp_path / "run"
    proc = run_cli(out, duration=5.0)
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]
    published = json.loads((out / "published.json").read_text())
    with Reader(out / "bag") as reader:
        recorded = {c.topic: c.msgcount for c in reader.connections}
    for topic in (*EXPECTED_TOPICS, "/diagnostics", "/motor/command_receipts"):
        assert published[topic] > 0, topic
        assert recorded[topic] == published[topic], topic
    missed = [line for line in proc.stdout.splitlines() if "the bag misses" in line]
    assert json.loads((out / "metrics.json").read_text())["unrecorded_messages"] == 0, missed


def _realtime_threads(tmp_path, *extra) -> dict[int, list[int]]:
    """Run the stack; once the loop runs, each process's SCHED_FIFO/RR threads."""
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "robot_controller.cli",
            "run",
            "--duration",
            "3",
            "--out",
            str(tmp_path / f"run{len(extra)}"),
            *extra,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    found: dict[int, list[int]] = {}
    for line in proc.stdout:
        if "control loop running" in line:
            for pid in _descendants(proc.pid):
                for tid in map(int, os.listdir(f"/proc/{pid}/task") if os.path.isdir(f"/proc/{pid}/task") else []):
                    try:
                        if os.sched_getscheduler(tid) in (os.SCHED_FIFO, os.SCHED_RR):
                            found.setdefault(pid, []).append(tid)
                    except OSError:
                        pass
            break
    output = proc.stdout.read()
    assert proc.wait(timeout=120) == 0, run_said(output)
    return found


def test_no_thread_runs_real_time_unless_asked(tmp_path, ros_domain):
    """The kernel's throttling of SCHED_FIFO tasks froze the whole loop: by
    default nothing is real-time; --realtime makes one thread so (where permitted)."""
    assert _realtime_threads(tmp_path) == {}
    if os.geteuid() != 0:
        pytest.skip("SCHED_FIFO needs root or CAP_SYS_NICE")
    asked = _realtime_threads(tmp_path, "--realtime")
    assert sum(len(tids) for tids in asked.values()) == 1, asked


def _descendants(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-e", "-o", "pid=,ppid="], capture_output=True, text=True).stdout.split()
    children: dict[int, list[int]] = {}
    for child, parent in zip(map(int, out[::2]), map(int, out[1::2]), strict=False):
        children.setdefault(parent, []).append(child)
    found, todo = [], [pid]
    while todo:
        current = todo.pop()
        found.append(current)
        todo.extend(children.get(current, []))
    return found


def robot_stopped_a_slow_host(figures: dict) -> bool:
    """The stand-in robot stopped the franka scenario's run for late commands, our tick's 99th percentile past its
    1 ms (a host too slow for the robot's clock: ``tests.hardware.stand_in``)."""
    failure, p99 = figures.get("franka_failure") or "", figures.get("franka_tick_p99_ms")
    return "communication_constraints_violation" in failure and isinstance(p99, float) and p99 > SLOW_TICK_P99_MS


@pytest.mark.slow
def test_bench_quick_writes_every_key(tmp_path, ros_domain):
    stand_in_venv()  # the Franka scenario drives the stand-in robot: made here if missing
    out = tmp_path / "bench"
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", "bench", "--quick", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=400,
    )
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]
    figures = json.loads((out / "bench.json").read_text(), parse_constant=lambda c: pytest.fail(f"{c} in JSON"))
    for key in (
        "wall100_jitter_p99_ms",
        "wall100_missed",
        "wall100_latency_p99_ms",
        "wall1k_missed_pct",
        "lockstep_rtf_multi",
        "lockstep_rtf_single",
        "core_steps_per_s",
        "batch_sim_s_per_s",
        "wall100_loaded_jitter_p99_ms",
        "wall100_loaded_missed",
        "hop_limit_rtf",
        "lockstep_rtf_vs_hop_limit",
        "hop_message_cpu_us",
        "franka_ok",
        "franka_tick_p99_ms",
        "franka_success_rate",
        "franka_tracking_rms_rad",
        "soak_missed",
        "soak_stalls_30ms",
        "soak_watchdog_ticks",
        "soak_jitter_p99_ms",
        "soak_jitter_max_ms",
        "soak_tracking_max_rad",
        "soak_rss_growth_mb",
        "cpu_pct_total",
        "cpu_pct_recorder",
        "loop_floor_panda_loop_vs_physics",
        "loop_floor_one_dof_controller_share",
        *(
            f"cpu_pct_{node}"
            for node in ("simulator", "motor_node", "sensor_node", "pid_controller", "trajectory_planner")
        ),
    ):
        if key == "franka_tracking_rms_rad" and robot_stopped_a_slow_host(figures):
            continue  # the robot stopped the run before its 2 s start was over: nothing to score
        assert isinstance(figures[key], (int, float)), key
    assert figures["lockstep_rtf_multi"] > 0 and figures["batch_sim_s_per_s"] > 0
    assert "| target | figure | met? |" in (out / "bench.md").read_text()
