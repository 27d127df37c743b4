"""The SCARA (description/scara_arm.urdf, a prismatic quill) through the real graph in lockstep:
scored, and its efforts checked, in each joint's own units."""

import json
import subprocess
import sys

import pytest

from tests.rostools import run_said

pytestmark = pytest.mark.ros


def test_the_scara_runs_its_quill_in_metres_and_newtons_within_its_limits(tmp_path, ros_domain):
    out = tmp_path / "scara"
    command = ["run", "--robot", "scara", "--sim-time", "--duration", "4", "--out", str(out)]
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", *command], capture_output=True, text=True, timeout=240
    )
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]
    for line in (  # what the nodes say at start, each joint in its unit
        "motor: torque limit ±[30 N·m, 10 N·m, 40 N]",
        "sensor at 100 Hz: σ position 0.005 rad or m, σ velocity 0.02 rad/s or m/s",
        "trajectory: sine, amplitude [0.6 rad, 0.8 rad, 0.05 m]",
        "|torque| <= [30 N·m, 10 N·m, 40 N]",
    ):
        assert line in proc.stdout, line
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["robot"] == "scara" and metrics["joint_names"] == ["shoulder", "elbow", "quill"]
    assert metrics["joint_units"] == ["rad", "rad", "m"]
    assert metrics["tracking_rms_rad"] == max(metrics["tracking_rms_per_joint"][:2]) < 0.002
    assert metrics["tracking_rms_m"] == metrics["tracking_rms_per_joint"][2] < 0.001
    assert metrics["saturated_ticks"] == 0
    peaks, limits = metrics["peak_effort_per_joint"], [30.0, 10.0, 40.0]  # N·m, N·m, N
    assert all(peak < limit for peak, limit in zip(peaks, limits, strict=True)), peaks
    assert metrics["peak_force_n"] == peaks[2] > 9.0  # it holds the quill's 1 kg up: 9.81 N
