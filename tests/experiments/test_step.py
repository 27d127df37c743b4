"""Step responses over the real graph in lockstep."""

import json
import subprocess
import sys

import pytest

from tests.rostools import run_said

pytestmark = pytest.mark.ros


def test_step_response_meets_the_targets(tmp_path, ros_domain):
    out = tmp_path / "step"
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", "step", "--sim-time", "--amplitude", "0.5", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=180,
    )
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]
    figures = json.loads((out / "metrics.json").read_text())
    assert figures["overshoot_pct"] <= 2.0
    assert figures["settling_time_s"] <= 0.25
    assert figures["peak_torque_nm"] <= 10.0
    assert abs(figures["steady_state_error_rad"]) < 0.005
    assert (out / "step.png").stat().st_size > 10_000
