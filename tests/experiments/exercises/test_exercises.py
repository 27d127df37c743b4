"""The tutorial's exercises (robot_controller.experiments.exercises): the quick forms over the real
graph in lockstep, and their no-ROS parts."""

import json

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller.experiments.exercises import EXERCISES
from robot_controller.experiments.exercises.ziegler_nichols import oscillation
from robot_controller.experiments.loop_model import law_gains
from robot_controller.experiments.step import Response

ros = pytest.mark.ros


def run_quick(name, out):
    calls = []
    results = EXERCISES[name].run(out, quick=True, progress=calls.append)
    assert len(calls) == EXERCISES[name].steps(True), calls  # one progress step each, as announced
    assert (out / "report.md").read_text().startswith("# Exercise")
    assert any(path.stat().st_size > 10_000 for path in out.glob("*.png"))
    stored = json.loads((out / "results.json").read_text())
    assert all(value is None or isinstance(value, int | float) for value in stored.values()), "flat, numbers"
    assert stored == results
    return stored


def test_every_exercise_is_registered_with_its_steps():
    assert {"tune", "windup", "lqr"} <= set(EXERCISES)
    for name, exercise in EXERCISES.items():
        assert exercise.name == name and exercise.title
        assert 0 < exercise.steps(True) <= exercise.steps(False)


@ros
@pytest.mark.slow
def test_tune_finds_the_ultimate_gain_then_kd_then_ki(tmp_path, ros_domain):
    results = run_quick("tune", tmp_path / "tune")
    for key in (
        "ultimate_gain",
        "ultimate_period_s",
        "kp",
        "ki",
        "kd",
        "step_overshoot_pct",
        "step_settling_time_s",
        "step_steady_state_error_rad",
        "sine_tracking_rms_rad",
        "zn_kp",
        "zn_ki",
        "zn_kd",
    ):
        assert key in results, key
    # the tutorial's Kp = 50 already oscillates on this arm; the sampled model puts Ku near 20
    assert results["kp_search_1_kp"] == 50 and results["kp_search_1_sustained"] == 1
    assert results["ultimate_gain_bracket_low"] < results["ultimate_gain"] <= 50
    assert 10 <= results["ultimate_gain"] <= 40 and 0.2 < results["ultimate_period_s"] < 0.6
    assert results["kp"] == pytest.approx(0.6 * results["ultimate_gain"])
    assert results["ki"] > 0 and results["kd"] > 0
    assert results["sine_tracking_rms_rad"] < 1.0


@ros
@pytest.mark.slow
def test_windup_without_anti_windup_overshoots_most(tmp_path, ros_domain):
    results = run_quick("windup", tmp_path / "windup")
    for mode in ("none", "clamp", "back_calculation", "conditional_integration"):
        for key in ("overshoot_pct", "settling_time_s", "saturated_s"):
            assert f"{mode}_{key}" in results, f"{mode}_{key}"
        assert results[f"{mode}_saturated_s"] > 0.1  # the 1 rad jump saturates a 2 N·m actuator
    assert results["none_overshoot_pct"] > results["conditional_integration_overshoot_pct"] + 5
    assert results["none_integral_max_nm"] > 2.0  # wound up beyond what the motor can give


@ros
@pytest.mark.slow
def test_lqr_against_pid_gains_poles_and_figures(tmp_path, ros_domain):
    results = run_quick("lqr", tmp_path / "lqr")
    for name in ("pid", "lqr"):
        for key in (
            "kp",
            "ki",
            "kd",
            "spectral_radius",
            "sine_tracking_rms_rad",
            "step_overshoot_pct",
            "step_settling_time_s",
        ):
            assert f"{name}_{key}" in results, f"{name}_{key}"
        poles = [value for key, value in results.items() if key.startswith(f"{name}_pole_") and key.endswith("_abs")]
        assert len(poles) == 3 and all(p < 1.0 for p in poles)
    assert (results["pid_kp"], results["pid_ki"], results["pid_kd"]) == (50, 10, 5)
    lqr = law_gains(cfg.merge(cfg.load_stack("tutorial"), {"pid_controller": {"controller_type": "lqr"}}))
    assert results["lqr_kp"] == pytest.approx(float(lqr.kp[0]))
    assert results["lqr_sine_tracking_rms_rad"] < results["pid_sine_tracking_rms_rad"]


def _response(growth_per_s: float) -> Response:
    t = np.arange(0.0, 4.0, 0.01)
    q = 0.2 + 0.1 * np.exp(growth_per_s * t) * np.sin(2 * np.pi * t / 0.4)
    zeros = np.zeros_like(t)
    return Response("synthetic", t, zeros + 0.2, q, zeros, zeros, zeros.astype(bool))


@pytest.mark.parametrize("growth, sustained", [(-0.5, 0), (-0.1, 0), (0.0, 1), (0.3, 1)])
def test_an_oscillation_is_sustained_when_its_amplitude_does_not_decay(growth, sustained):
    figures = oscillation(_response(growth))
    assert figures["sustained"] == sustained
    assert figures["growth_per_s"] == pytest.approx(growth, abs=0.05)
    assert figures["period_s"] == pytest.approx(0.4, rel=0.02)
