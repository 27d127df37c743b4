"""Part of the graph per launcher (``run --nodes/--peers/--run-id``): two
launchers on one host, on one ROS_DOMAIN_ID, make one loop over UDP; the one
with the simulator records and scores it, the other says what it ran."""

import json
import subprocess
import sys

import pytest

pytestmark = pytest.mark.ros

ROBOT_SIDE = "simulator,motor_node,sensor_node,pid_controller"


def launcher(out, *args):
    return subprocess.Popen(
        [sys.executable, "-m", "robot_controller.cli", "run", "--out", str(out), *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )


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
    assert robot.returncode == 0, robot_out[-3000:]
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
