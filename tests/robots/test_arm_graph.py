"""An arm known only by its description (example-robot-data's UR5) through the real graph in lockstep."""

import json
import subprocess
import sys

import pytest

from tests.rostools import run_said

pytestmark = pytest.mark.ros


def test_the_ur5_from_its_description_runs_named_and_within_its_effort_limits(tmp_path, ros_domain):
    out = tmp_path / "ur5"
    command = ["run", "--robot", "ur5", "--sim-time", "--duration", "2", "--out", str(out)]
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", *command], capture_output=True, text=True, timeout=240
    )
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]
    assert "[launcher] ur5: 7 visual(s) MuJoCo cannot read dropped" in proc.stdout  # said once, before the run
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["robot"] == "ur5" and len(metrics["joint_names"]) == 6
    assert metrics["tracking_rms_rad"] < 0.005 and metrics["saturated_ticks"] == 0
    peaks, limits = metrics["peak_torque_nm_per_joint"], [150.0] * 3 + [28.0] * 3
    assert all(peak < limit for peak, limit in zip(peaks, limits, strict=True)), peaks
