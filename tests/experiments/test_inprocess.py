"""The whole loop in one Python loop (no ROS): accuracy, determinism, limits."""

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller.experiments import inprocess


@pytest.fixture(scope="module")
def default_run():
    return inprocess.simulate(cfg.load_stack("default"), duration_s=8.0, seed=3)


def test_default_preset_tracks_the_true_angle(default_run):
    assert default_run.tracking_metrics()["tracking_rms_rad"] < 0.003


def test_tutorial_preset_lags_as_the_tutorial_controller_does():
    rms = inprocess.simulate(cfg.load_stack("tutorial"), duration_s=8.0, seed=3).tracking_metrics()["tracking_rms_rad"]
    assert 0.1 < rms < 0.35


def test_same_seed_same_run(default_run):
    again = inprocess.simulate(cfg.load_stack("default"), duration_s=8.0, seed=3)
    np.testing.assert_array_equal(again.true_position, default_run.true_position)
    other = inprocess.simulate(cfg.load_stack("default"), duration_s=8.0, seed=4)
    assert not np.array_equal(other.measured, default_run.measured)


def test_torque_is_finite_and_within_the_limit(default_run):
    assert np.all(np.isfinite(default_run.command))
    assert np.max(np.abs(default_run.applied)) <= 10.0


def test_latency_compensation_holds_accuracy_under_measurement_delay():
    params = cfg.load_stack("default")
    delayed = inprocess.simulate(params, duration_s=6.0, seed=1, measurement_delay_s=0.02).tracking_metrics()
    assert delayed["tracking_rms_rad"] < 0.003
    params["pid_controller"]["latency_compensation"] = False
    uncompensated = inprocess.simulate(params, duration_s=6.0, seed=1, measurement_delay_s=0.02).tracking_metrics()
    assert uncompensated["tracking_rms_rad"] > 5 * delayed["tracking_rms_rad"]


@pytest.mark.parametrize("delay_s", [0.02, 0.04, 0.06])
def test_readings_up_to_60_ms_late_are_compensated_without_saturation(delay_s):
    run = inprocess.simulate(cfg.load_stack("default"), duration_s=6.0, seed=1, measurement_delay_s=delay_s)
    assert run.tracking_metrics()["tracking_max_rad"] < 0.01
    assert np.max(np.abs(run.command)) < 9.0


def test_the_default_survives_its_delay_margin_of_delay_nobody_accounts_for():
    # Stamped on arrival, the delay is invisible to the compensation: only the
    # loop's own margin (2 periods for the default LQR design with its disturbance
    # observer, 3 without it) keeps the loop stable.
    from robot_controller import resources
    from robot_controller.core.controller import JointController
    from robot_controller.core.plant import ArmDynamics

    params = cfg.load_stack("default")
    controller = JointController(
        cfg.controller_config(params["pid_controller"], 1), 1, ArmDynamics(resources.default_urdf())
    )
    margin = controller.delay_margin_periods()
    assert margin >= 2
    run = inprocess.simulate(params, duration_s=6.0, seed=1, measurement_delay_s=margin * 0.01, delay_unstamped=True)
    assert np.max(np.abs(run.command)) < 10.0  # no saturation chatter
    # The arm follows where the late readings say it is: off by the speed times the delay, no more.
    assert run.tracking_metrics()["tracking_max_rad"] < 3.2 * margin * 0.01 * 1.5
    params["pid_controller"]["lqr_r"] = 0.01  # the old default's gains: no margin at all
    twitchy = inprocess.simulate(params, duration_s=6.0, seed=1, measurement_delay_s=0.02, delay_unstamped=True)
    assert np.max(np.abs(twitchy.command)) >= 10.0
