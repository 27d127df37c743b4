"""Metrics on signals with known answers."""

import numpy as np
import pytest
from scipy import signal

from robot_controller.core import metrics
from robot_controller.core.controller import state_layout


def test_tracking_metrics_known_offset_and_warmup():
    t = np.arange(0, 10, 0.01)
    ref = np.sin(t)
    true = ref - 0.01
    true[:100] += 5.0  # inside the 2 s warm-up: ignored
    out = metrics.tracking_metrics(t, ref, true, ref + 0.02)
    assert out["tracking_rms_rad"] == pytest.approx(0.01)
    assert out["tracking_max_rad"] == pytest.approx(0.01)
    assert out["measured_rms_rad"] == pytest.approx(0.02)
    assert out["scored_ticks"] == 800


def test_true_position_interpolation_is_accurate_between_samples():
    t_true = np.arange(0, 5, 0.005)
    q, v = np.sin(np.pi * t_true), np.pi * np.cos(np.pi * t_true)
    ticks = np.arange(0.0013, 4.9, 0.01)
    est = metrics.true_position_at(ticks, t_true, q[:, None], v[:, None])[:, 0]
    np.testing.assert_allclose(est, np.sin(np.pi * ticks), atol=1e-7)


def test_metrics_are_invariant_to_a_time_shift():
    t = np.arange(0, 6, 0.01)
    ref, true = np.sin(t), np.sin(t - 0.01)
    a = metrics.tracking_metrics(t, ref, true, true)
    b = metrics.tracking_metrics(t + 1e6, ref, true, true)
    assert a == b


def test_rate_metrics():
    t = np.arange(0, 10, 0.01)
    t[500:] += 0.02  # one late tick: a 30 ms period, two ticks lacking
    out = metrics.rate_metrics(t, 0.01)
    assert out["missed_cycles"] == 2  # as the rate says: 999 periods where 1001 fit
    assert round(out["control_rate_hz"] * (t[-1] - t[0])) + out["missed_cycles"] == round((t[-1] - t[0]) / 0.01)
    assert out["jitter_max_ms"] == pytest.approx(20.0)
    assert out["control_rate_hz"] == pytest.approx(999 / (9.99 + 0.02))


def test_only_the_host_misses_among_the_scored_periods_are_counted():
    ticks = np.arange(1.0, 2.0, 0.01)
    # Before the first recorded tick, at it (no period of the recording ends there), inside, at the last, after.
    count = metrics.periods_ending_within([0.5, 1.0, 1.5, ticks[-1], 2.5], ticks)
    assert count == 2 and type(count) is int  # (a NumPy integer is no JSON)
    assert metrics.periods_ending_within([1.5], ticks[:1]) == 0


def test_a_period_a_little_long_misses_one_tick_and_the_hosts_are_matched_to_their_periods():
    t = np.arange(0, 1, 0.01)
    t[10:] += 0.006  # 16 ms: one tick lacking
    t[50:] += 0.025  # 35 ms: the 45 ms period lacks 3 (rounded: 3.5 periods over)
    assert metrics.rate_metrics(t, 0.01)["missed_cycles"] == 1 + 3
    # The host made the 35 ms one (its end said to within a jitter); an end at no tick of the recording counts nothing.
    assert metrics.missed_ticks_ending_at([t[50] + 0.002], t, 0.01) == 3
    assert metrics.missed_ticks_ending_at([t[30] + 0.005, 5.0], t, 0.01) == 0
    assert metrics.missed_ticks_ending_at([t[50], t[50]], t, 0.01) == 3  # said twice: once


def test_step_metrics_on_a_second_order_system():
    zeta, wn = 0.5, 10.0
    t = np.linspace(0, 3, 30001)
    _, y = signal.step(([wn**2], [1, 2 * zeta * wn, wn**2]), T=t)
    out = metrics.step_metrics(t, 0.5 * y, initial=0.0, target=0.5)
    expected_overshoot = 100 * np.exp(-zeta * np.pi / np.sqrt(1 - zeta**2))
    assert out["overshoot_pct"] == pytest.approx(expected_overshoot, rel=1e-3)
    # 2 % settling of this system (computed from the envelope) lies within ~[0.7, 0.85] s
    assert 0.6 < out["settling_time_s"] < 0.9
    assert out["steady_state_error_rad"] < 1e-3
    first_order = 0.5 * (1 - np.exp(-t / 0.1))
    assert metrics.step_metrics(t, first_order, initial=0, target=0.5)["rise_time_s"] == pytest.approx(
        0.1 * np.log(9), rel=1e-3
    )


def test_controller_state_layout_round_trips():
    values = {name: np.array([k + 0.5, k + 1.5]) for k, name in enumerate(state_layout.FIELDS)}
    data = state_layout.encode(12.5, "watchdog", 12.49, 2, values)
    assert len(data) == state_layout.width(2)
    back = state_layout.decode(np.array(data), 2)
    assert back["time_s"] == 12.5 and back["status"] == state_layout.STATUS_CODES["watchdog"]
    assert back["measurement_stamp_s"] == 12.49
    for name in state_layout.FIELDS:
        np.testing.assert_array_equal(back[name], values[name])


def test_true_position_is_unknown_across_a_gap_in_the_samples():
    # The simulator was not running from 1.0 to 2.0 s: no invented swing in between.
    t_true = np.concatenate([np.arange(0, 1.0001, 0.01), np.arange(2.0, 3.0, 0.01)])
    q = np.sin(t_true)[:, None]
    v = np.cos(t_true)[:, None]
    est = metrics.true_position_at(np.array([0.505, 1.5, 2.505]), t_true, q, v)[:, 0]
    assert abs(est[0] - np.sin(0.505)) < 1e-6 and abs(est[2] - np.sin(2.505)) < 1e-6
    assert np.isnan(est[1])


def test_each_joint_is_scored_and_the_worst_is_the_headline():
    t = np.arange(0, 10, 0.01)
    ref = np.column_stack([np.sin(t), np.cos(t)])
    true = ref - [0.01, -0.03]  # the second joint tracks three times worse
    measured = ref + [0.02, 0.005]
    out = metrics.tracking_metrics(t, ref, true, measured)
    assert out["tracking_rms_rad_per_joint"] == pytest.approx([0.01, 0.03])
    assert out["tracking_max_rad_per_joint"] == pytest.approx([0.01, 0.03])
    assert out["measured_rms_rad_per_joint"] == pytest.approx([0.02, 0.005])
    assert out["tracking_rms_rad"] == pytest.approx(0.03)  # not the pooled 0.0224
    assert out["tracking_max_rad"] == pytest.approx(0.03)
    assert out["measured_rms_rad"] == pytest.approx(0.02)  # the worst joint here is the first
    torque = metrics.peak_torque(np.column_stack([3.0 * np.sin(t), -7.0 * np.cos(t)]))
    assert torque["peak_torque_nm_per_joint"] == pytest.approx([3.0, 7.0], abs=1e-3)
    assert torque["peak_torque_nm"] == torque["peak_torque_nm_per_joint"][1]


def test_one_joint_figures_are_the_pooled_ones_exactly():
    rng = np.random.default_rng(7)
    error = rng.normal(0.0, 0.01, (1234, 1))
    out = metrics.joint_errors(error)
    assert out["tracking_rms_rad"] == float(np.sqrt(np.mean(error**2)))  # bit for bit, as before
    assert out["tracking_max_rad"] == float(np.max(np.abs(error)))
    assert out["tracking_rms_rad_per_joint"] == [out["tracking_rms_rad"]]
    command = rng.normal(0.0, 3.0, (500, 1))
    assert metrics.peak_torque(command)["peak_torque_nm"] == float(np.max(np.abs(command)))


def test_a_prismatic_joint_is_scored_in_m_and_the_rad_headline_is_the_revolute_joints():
    error = np.tile([0.002, -0.001, 0.0005], (100, 1))  # rad, rad, m (a quill 0.5 mm off)
    out = metrics.joint_errors(error, units=["rad", "rad", "m"])
    assert out["tracking_rms_per_joint"] == pytest.approx([0.002, 0.001, 0.0005])
    assert out["tracking_rms_rad"] == pytest.approx(0.002)  # the shoulder's, the quill's metres kept out
    assert out["tracking_rms_m"] == out["tracking_max_m"] == pytest.approx(0.0005)
    assert "tracking_rms_rad_per_joint" not in out  # a list named rad would carry metres
    efforts = metrics.peak_torque(np.tile([3.0, -1.0, 12.0], (10, 1)), ["rad", "rad", "m"])
    assert efforts["peak_torque_nm"] == 3.0 and efforts["peak_force_n"] == 12.0
    assert efforts["peak_effort_per_joint"] == [3.0, 1.0, 12.0] and "peak_torque_nm_per_joint" not in efforts
    only_slides = metrics.joint_errors(error[:, 2:], units=["m"])
    assert np.isnan(only_slides["tracking_rms_rad"]) and only_slides["tracking_rms_m"] == pytest.approx(0.0005)


def test_revolute_joints_keep_their_keys_and_gain_the_unit_free_lists():
    error = np.random.default_rng(3).normal(0.0, 0.01, (500, 2))
    out, given = metrics.joint_errors(error), metrics.joint_errors(error, units=["rad", "rad"])
    assert out == given and "tracking_rms_m" not in out
    assert out["tracking_rms_rad_per_joint"] == out["tracking_rms_per_joint"]
    assert out["tracking_rms_rad"] == max(out["tracking_rms_per_joint"])
    assert "peak_force_n" not in metrics.peak_torque(error)


def test_values_are_said_in_their_units_as_before_when_every_joint_shares_one():
    assert metrics.in_units([30.0, 10.0], ["N·m", "N·m"]) == "[30.0, 10.0] N·m"  # the motor's line, as it was
    assert metrics.in_units([313.2, 37.01], ["N·m/rad"] * 2, ".3g") == "[313, 37] N·m/rad"
    assert metrics.in_units([30.0, 10.0, 40.0], ["N·m", "N·m", "N"]) == "[30 N·m, 10 N·m, 40 N]"
    assert metrics.in_units([0.5], ["rad", "m"]) == "[0.5 rad, 0.5 m]"  # one value for every joint
    assert metrics.in_units([1e4, 1.0], spec=".3g") == "[1e+04, 1]"
