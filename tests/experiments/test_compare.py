"""The controller comparison over the real graph in lockstep."""

import json
import subprocess
import sys

import pytest

from tests.rostools import run_said

pytestmark = pytest.mark.ros


@pytest.mark.slow
def test_compare_lists_every_controller(tmp_path, ros_domain):
    out = tmp_path / "compare"
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", "compare", "--seeds", "1", "--duration", "3", "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=400,
    )
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]
    table = (out / "compare.md").read_text()
    for name in ("tutorial", "pid", "pid_ff", "pid_ff_kf", "lqr"):
        assert f"| **{name}**" in table, name
    figures = json.loads((out / "compare.json").read_text())
    # the tutorial's controller lags the sine; ours tracks it
    assert figures["tutorial"]["sine_tracking_rms_rad"]["mean"] > 10 * figures["lqr"]["sine_tracking_rms_rad"]["mean"]
    assert (out / "compare.png").stat().st_size > 10_000
