"""Arms known only by their descriptions through the real graph in lockstep: example-robot-data's UR5,
and the SCARA (description/scara_arm.urdf, a prismatic quill) scored and checked in each joint's own units."""

import json
import subprocess
import sys

import pytest

from tests.rostools import run_said

pytestmark = pytest.mark.ros


def run_arm(tmp_path, robot: str, duration_s: float) -> tuple[str, dict]:
    """``run --robot ROBOT --sim-time`` for ``duration_s``: what it printed and its metrics (it must exit 0)."""
    out = tmp_path / robot
    command = ["run", "--robot", robot, "--sim-time", "--duration", str(duration_s), "--out", str(out)]
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", *command], capture_output=True, text=True, timeout=240
    )
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]
    return proc.stdout, json.loads((out / "metrics.json").read_text())


def test_the_ur5_from_its_description_runs_named_and_within_its_effort_limits(tmp_path, ros_domain):
    said, metrics = run_arm(tmp_path, "ur5", 2)
    assert "[launcher] ur5: 7 visual(s) MuJoCo cannot read dropped" in said  # said once, before the run
    assert metrics["robot"] == "ur5" and len(metrics["joint_names"]) == 6
    assert metrics["tracking_rms_rad"] < 0.005 and metrics["saturated_ticks"] == 0
    peaks, limits = metrics["peak_torque_nm_per_joint"], [150.0] * 3 + [28.0] * 3
    assert all(peak < limit for peak, limit in zip(peaks, limits, strict=True)), peaks


def test_the_scara_runs_its_quill_in_metres_and_newtons_within_its_limits(tmp_path, ros_domain):
    said, metrics = run_arm(tmp_path, "scara", 4)
    for line in (  # what the nodes say at start, each joint in its unit
        "motor: torque limit ±[30 N·m, 10 N·m, 40 N]",
        "sensor at 100 Hz: σ position 0.005 rad or m, σ velocity 0.02 rad/s or m/s",
        "trajectory: sine, amplitude [0.6 rad, 0.8 rad, 0.05 m]",
        "|torque| <= [30 N·m, 10 N·m, 40 N]",
    ):
        assert line in said, line
    assert metrics["robot"] == "scara" and metrics["joint_names"] == ["shoulder", "elbow", "quill"]
    assert metrics["joint_units"] == ["rad", "rad", "m"]
    assert metrics["tracking_rms_rad"] == max(metrics["tracking_rms_per_joint"][:2]) < 0.002
    assert metrics["tracking_rms_m"] == metrics["tracking_rms_per_joint"][2] < 0.001
    assert metrics["saturated_ticks"] == 0
    peaks, limits = metrics["peak_effort_per_joint"], [30.0, 10.0, 40.0]  # N·m, N·m, N
    assert all(peak < limit for peak, limit in zip(peaks, limits, strict=True)), peaks
    assert metrics["peak_force_n"] == peaks[2] > 9.0  # it holds the quill's 1 kg up: 9.81 N
