"""The whole loop in one Python loop (no ROS): accuracy, determinism, limits."""
import numpy as np
import pytest

from robot_controller import config as cfg
from robot_controller import inprocess


@pytest.fixture(scope="module")
def default_run():
    return inprocess.simulate(cfg.load_stack("default"), duration_s=8.0, seed=3)


def test_default_preset_tracks_the_true_angle(default_run):
    assert default_run.tracking_metrics()["tracking_rms_rad"] < 0.003


def test_seed_preset_lags_as_the_tutorial_controller_does():
    rms = inprocess.simulate(cfg.load_stack("seed"), duration_s=8.0, seed=3).tracking_metrics()["tracking_rms_rad"]
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
