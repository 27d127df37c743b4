"""A run's options: built once from the parsed arguments (``RunOptions.from_args``), the configuration
checked once per ``run``, before the output folder is made. No ROS: the launcher is not started."""

import math
from pathlib import Path

import pytest

from robot_controller import cli
from robot_controller.parameters import consistency
from robot_controller.runner import launcher, plan
from robot_controller.runner.options import RunOptions


def options_of(*argv: str) -> RunOptions:
    return RunOptions.from_args(cli.build_parser().parse_args(list(argv)))


def test_the_options_are_read_from_the_arguments():
    options = options_of(
        "run",
        "--duration",
        "5",
        "--sim-time",
        "--seed",
        "3",
        "--config",
        "a.yaml",
        "--config",
        "b.yaml",
        "--nodes",
        "trajectory_planner",
        "--run-id",
        "r1",
        "--peers",
        "10.0.0.2",
        "--wait",
        "7",
    )
    assert options == RunOptions(
        duration_s=5.0,
        sim_time=True,
        seed=3,
        config=(Path("a.yaml"), Path("b.yaml")),
        nodes=("trajectory_planner",),
        run_id="r1",
        peers=("10.0.0.2",),
        wait_s=7.0,
    )
    assert options_of("run").view_port is None  # the port only with --view
    assert options_of("run", "--view", "--view-port", "9191").view_port == 9191
    step = options_of("step", "--robot", "planar2", "--preset", "tutorial")
    assert (step.robot, step.preset, step.seed, step.duration_s) == ("planar2", "tutorial", 0, math.inf)
    assert options_of("tune").seed is None  # no --seed: the stack's own


def test_run_checks_the_configuration_once(tmp_path, monkeypatch):
    checks = []
    real_check = consistency.check_stack
    monkeypatch.setattr(consistency, "check_stack", lambda params: checks.append(params) or real_check(params))
    launched = []

    def launch(checked: plan.CheckedRun, out_dir: Path, watcher=None) -> launcher.RunResult:
        launched.append(checked)
        return launcher.RunResult(out_dir / "bag", recorded=False, local_nodes=checked.options.nodes)

    monkeypatch.setattr(launcher, "launch", launch)
    assert cli.main(["run", "--sim-time", "--duration", "3", "--out", str(tmp_path / "run")]) == 0
    assert len(checks) == 1
    (checked,) = launched
    assert checked.params is checks[0]
    assert checked.params["simulator"]["lockstep_end_s"] == pytest.approx(3.5)
    assert checked.options.duration_s == 3.0 and checked.options.sim_time


def test_a_configuration_refused_leaves_no_output_folder(tmp_path, monkeypatch):
    monkeypatch.setattr(launcher, "launch", lambda *args, **kwargs: pytest.fail("launched"))
    path = tmp_path / "fast.yaml"
    path.write_text("pid_controller:\n  ros__parameters:\n    control_rate_hz: 1000\n")
    assert cli.main(["run", "--config", str(path), "--out", str(tmp_path / "run")]) == 2
    assert not (tmp_path / "run").exists()
