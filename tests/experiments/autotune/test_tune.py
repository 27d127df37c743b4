"""Automatic gain design (robot_controller.experiments.autotune): a built-in law on the batch harness
(the search's margins and harness; the quick form over the real graph) and a law of one's own
on the in-process loop."""

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from robot_controller import cli
from robot_controller import parameters as cfg
from robot_controller.core.batch import run_batch
from robot_controller.experiments import autotune, laws
from robot_controller.experiments.autotune.analytic import AnalyticProblem
from robot_controller.experiments.autotune.blackbox import CASES, BlackBoxProblem
from robot_controller.experiments.autotune.margins import describe_margins
from robot_controller.experiments.autotune.search import search
from robot_controller.experiments.loop_model import law_gains

ros = pytest.mark.ros
PD = str(Path(__file__).resolve().parents[3] / "examples" / "own_controller.py") + ":PDWithGravity"


@ros
@pytest.mark.slow
def test_tune_writes_a_robust_parameter_file(tmp_path, ros_domain):
    out = tmp_path / "tuned"
    calls = []
    values = autotune.tune(cfg.load_stack("tutorial"), out, quick=True, progress=calls.append)
    assert len(calls) == autotune.steps(quick=True)
    stored = json.loads((out / "tune.json").read_text())
    assert stored["after_meets_constraints"] == 1
    assert stored["after_gain_margin_db"] >= 6.0 and stored["after_phase_margin_deg"] >= 45.0
    assert stored["after_delay_margin_periods"] >= 2
    assert stored["batch_rms_after_rad"] <= stored["batch_rms_before_rad"]
    assert stored["real_rms_after_rad"] > 0 and stored["real_rms_before_rad"] > 0
    params = cfg.load_stack("default", [out / "tuned.yaml"])
    assert params["pid_controller"]["kp"] == [values["after_kp"]]
    assert "| **after**" in (out / "report.md").read_text()


def test_the_lqr_weights_tuned_keep_the_margins_and_design_what_was_checked():
    problem = AnalyticProblem(cfg.load_stack("default"))
    result = search(problem, problem.plan(quick=True))
    best_gains = problem.gains_of_values(result.best_values)[0]
    margins = describe_margins(problem, best_gains)
    assert margins["meets_constraints"] == 1
    overlay = result.problem.overlay(result.best_values)
    designed = law_gains(cfg.merge(cfg.load_stack("default"), {"pid_controller": overlay}))
    assert (float(designed.kp[0]), float(designed.ki[0]), float(designed.kd[0])) == pytest.approx(
        tuple(best_gains), rel=1e-9
    )


def test_the_tuning_harness_is_the_batch_harness():
    problem = AnalyticProblem(cfg.load_stack("default"))
    gains = np.array([[30.0, 27.0, 2.1], [15.0, 0.4, 3.4], [50.0, 10.0, 5.0]])
    pid = replace(problem.law, kp=gains[:, 0:1], ki=gains[:, 1:2], kd=gains[:, 2:3])
    kwargs = {"trajectory": problem.sine, "sensor": problem.sensor, "duration_s": 3.0}
    ours = problem.tracking_rms(gains, 3.0, seed=4)
    harness = {"control_period_s": problem.dt, "torque_max": problem.torque_max, "feedforward": problem.feedforward}
    rng = np.random.default_rng(4)
    expected = run_batch(
        model=problem.arm_model, pid_config=pid, rng=rng, kalman=problem.kalman, common_noise=True, **harness, **kwargs
    )
    np.testing.assert_array_equal(ours, expected)
    # common random numbers: the same gains give the same figure wherever they sit in the batch
    twice = problem.tracking_rms(gains[[0, 0]], 3.0, seed=4)
    assert twice[0] == twice[1]


def test_robustness_cases_see_a_pd_too_fast_for_two_periods_of_delay():
    """PDWithGravity on the 1-joint arm: a discrete PD with two periods of delay is unstable above about
    4.5 Hz (ζ 0.88; the sampled loop's poles), so the delay case rejects 8 Hz and passes 3 Hz."""
    problem = BlackBoxProblem(laws.with_controller(cfg.load_stack(), PD))
    delay = CASES[0]
    assert delay.name == "delay"
    assert not problem.push_decay(np.array([8.0, 1.0]), delay)["ok"]
    assert problem.push_decay(np.array([3.0, 1.0]), delay)["ok"]


@ros
@pytest.mark.slow
def test_tune_of_a_plugin_law_writes_its_gains(tmp_path, ros_domain):
    """From a slow start (1 Hz): the design found beats it on the real graph, so it is written to use."""
    out, slow = tmp_path / "tune", tmp_path / "slow.yaml"
    cfg.write_params_file({"pid_controller": {"controller_type": PD, "law.natural_frequency_hz": 1.0}}, slow)
    assert cli.main(["tune", "--controller", PD, "--config", str(slow), "--quick", "--out", str(out)]) == 0
    tuned = yaml.safe_load((out / "tuned.yaml").read_text())["pid_controller"]["ros__parameters"]
    assert set(tuned) == {"controller_type", "law.natural_frequency_hz", "law.damping_ratio"}
    assert tuned["controller_type"] == PD
    values = json.loads((out / "tune.json").read_text())
    assert values["after_meets_constraints"] == 1
    assert values["after_delay_margin_periods"] >= 2
    assert 0.5 <= values["after_natural_frequency_hz"] <= 30.0
    assert values["after_check_rms_rad"] < 0.02
    assert "# Automatic gain design" in (out / "report.md").read_text()
    assert values["verification_recommended"] == 1
    assert values["verification_real_rms_after_rad"] < values["verification_real_rms_before_rad"]
