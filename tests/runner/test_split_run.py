"""Part of the graph per launcher (``run --nodes/--peers/--run-id``): two
launchers on one host, on one ROS_DOMAIN_ID, make one loop over UDP; the one
with the simulator records and scores it, the other says what it ran."""

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.ros

ROBOT_SIDE = "simulator,motor_node,sensor_node,pid_controller"
REPO = Path(__file__).resolve().parents[2]


def launcher(out, *args, prefix=(), env=None):
    return subprocess.Popen(
        [*prefix, sys.executable, "-m", "robot_controller.cli", "run", "--out", str(out), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=env,
    )


def shifted_clock(offset_s):
    """A command prefix and environment that run a process with its wall clock ``offset_s`` ahead (its monotonic
    clock untouched): Debian's faketime, installed by ``make faketime`` when missing."""
    if shutil.which("faketime") is None:
        made = subprocess.run(["make", "-C", str(REPO), "faketime"], capture_output=True, text=True, timeout=900)
        if shutil.which("faketime") is None:
            pytest.skip(f"faketime is not installed and `make faketime` could not install it: {made.stderr[-300:]}")
    # libfaketime's offset is in seconds ("+0.005"); "+5m" would be five minutes. Its time.sleep fix: faketime_site.
    site = str(Path(__file__).with_name("faketime_site"))
    path = os.pathsep.join([site, *filter(None, [os.environ.get("PYTHONPATH")])])
    return ["faketime", "-f", f"{offset_s:+g}"], dict(os.environ, FAKETIME_DONT_FAKE_MONOTONIC="1", PYTHONPATH=path)


def split_run(tmp_path, ros_domain, control_offset_s, duration_s="4"):
    """The robot side here, the controller and planner on a clock ``control_offset_s`` ahead: (exit codes, outputs)."""
    common = ["--peers", "127.0.0.1", "--run-id", f"clock-{ros_domain}", "--wait", "60"]
    prefix, env = shifted_clock(control_offset_s)
    robot = launcher(
        tmp_path / "robot", "--nodes", "simulator,motor_node,sensor_node", "--duration", duration_s, *common
    )
    nodes = "pid_controller,trajectory_planner"
    control = launcher(tmp_path / "control", "--nodes", nodes, *common, prefix=prefix, env=env)
    try:
        robot_out, _ = robot.communicate(timeout=150)
        control_out, _ = control.communicate(timeout=60)
    finally:
        for proc in (robot, control):
            if proc.poll() is None:
                proc.kill()
    return robot.returncode, control.returncode, robot_out, control_out


def ran(code: int, run_dir) -> bool:
    """The robot side's run ran to its end: ``ok``, or judged FAILED by its verdict (a wall-clock run on a shared host
    may brake for a command 50 ms late: said, exit 1), never a launcher's failure."""
    if code == 0:
        return True
    metrics = json.loads((run_dir / "metrics.json").read_text()) if (run_dir / "metrics.json").exists() else {}
    return code == 1 and metrics.get("verdict") == "failed" and metrics.get("run_failure") is None


def test_two_launchers_make_one_loop_over_udp(tmp_path, ros_domain):
    common = ["--peers", "127.0.0.1", "--run-id", f"split-{ros_domain}", "--wait", "60"]
    robot = launcher(tmp_path / "robot", "--nodes", ROBOT_SIDE, "--duration", "5", *common)
    control = launcher(tmp_path / "control", "--nodes", "trajectory_planner", *common)
    try:
        robot_out, _ = robot.communicate(timeout=150)
        control_out, _ = control.communicate(timeout=60)  # ends once the robot side's nodes have left
    finally:
        for proc in (robot, control):
            if proc.poll() is None:
                proc.kill()
    assert ran(robot.returncode, tmp_path / "robot"), robot_out[-3000:]
    assert control.returncode == 0, control_out[-3000:]
    metrics = json.loads((tmp_path / "robot" / "metrics.json").read_text())
    assert metrics["tracking_rms_rad"] < 0.02, metrics
    assert metrics["msgs_trajectory"] > 100  # the remote planner's samples reached the recorder
    assert metrics["reference_lost_ticks"] == 0
    assert "ran trajectory_planner for" in control_out and "left the graph" in control_out
    # Each side's profile is UDPv4 only, with the peer; the side without the simulator records nothing.
    for side in ("robot", "control"):
        profile = (tmp_path / side / "fastdds.xml").read_text()
        assert "<useBuiltinTransports>false</useBuiltinTransports>" in profile and "127.0.0.1" in profile
    assert not (tmp_path / "control" / "bag").exists() and not (tmp_path / "control" / "metrics.json").exists()


def test_a_launcher_whose_other_side_never_comes_gives_up_in_one_line(tmp_path, ros_domain):
    proc = launcher(
        tmp_path / "alone",
        "--nodes",
        "trajectory_planner",
        "--peers",
        "127.0.0.1",
        "--run-id",
        f"alone-{ros_domain}",
        "--wait",
        "3",
    )
    out, _ = proc.communicate(timeout=60)
    assert proc.returncode != 0, out[-2000:]
    failed = [line for line in out.splitlines() if line.startswith("[launcher] FAILED")]
    assert len(failed) == 1 and "within 3 s" in failed[0] and "simulator (other launcher)" in failed[0], out


def test_a_controller_on_a_clock_far_ahead_is_refused_in_one_line_naming_both_clocks(tmp_path, ros_domain):
    robot_code, _, robot_out, _ = split_run(tmp_path, ros_domain, 0.2)
    assert robot_code != 0, robot_out[-3000:]
    failed = [line for line in robot_out.splitlines() if line.startswith("[launcher] FAILED")]
    assert len(failed) == 1, robot_out[-3000:]
    assert re.search(r"is \+(19\d|20\d)\.\d ms from this one's", failed[0]), failed  # 200 ms, either way
    assert "pid_controller,trajectory_planner" in failed[0] and "max_command_age_s" in failed[0], failed
    assert "simulator,motor_node,sensor_node" in failed[0]
    assert "control loop running" not in robot_out


def test_a_controller_on_a_clock_a_little_ahead_runs_and_its_offset_is_reported(tmp_path, ros_domain):
    robot_code, control_code, robot_out, control_out = split_run(tmp_path, ros_domain, 0.005)
    assert ran(robot_code, tmp_path / "robot"), robot_out[-3000:]
    assert control_code == 0, control_out[-3000:]
    metrics = json.loads((tmp_path / "robot" / "metrics.json").read_text())
    assert abs(metrics["clock_offset_ms"] - 5.0) < 2.5, metrics  # the other launcher's clock minus this one's
    assert metrics["clock_round_trip_ms"] < 20.0
    assert metrics["tracking_rms_rad"] < 0.02, metrics  # as the split run above: a wall-clock run on a shared host
