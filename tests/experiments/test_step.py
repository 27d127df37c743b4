"""Step responses over the real graph in lockstep."""

import json
import subprocess
import sys

import pytest

from robot_controller import cli
from robot_controller.parameters import consistency
from robot_controller.runner import launcher
from tests.rostools import run_said


class Launched(BaseException):  # past the CLI's handler of unexpected exceptions
    pass


def test_step_checks_the_configuration_once_before_the_folder(tmp_path, monkeypatch):
    checks, launched = [], []
    real_check = consistency.check_stack
    monkeypatch.setattr(consistency, "check_stack", lambda params: checks.append(params) or real_check(params))

    def launch(checked, out_dir, watcher=None):
        launched.append((checked, out_dir.exists()))
        raise Launched

    monkeypatch.setattr(launcher, "launch", launch)
    with pytest.raises(Launched):
        cli.main(["step", "--sim-time", "--amplitude", "0.3", "--out", str(tmp_path / "step")])
    assert len(checks) == 1
    ((checked, folder_made),) = launched
    assert checked.params is checks[0] and folder_made
    assert checked.params["trajectory_planner"]["amplitude"] == [0.3]
    assert checked.options.duration_s == 2.5 and checked.options.sim_time

    path = tmp_path / "fast.yaml"
    path.write_text("pid_controller:\n  ros__parameters:\n    control_rate_hz: 1000\n")
    assert cli.main(["step", "--config", str(path), "--out", str(tmp_path / "refused")]) == 2
    assert not (tmp_path / "refused").exists() and len(launched) == 1


@pytest.mark.ros
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
