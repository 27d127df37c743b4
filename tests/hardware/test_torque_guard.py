"""The guard keeps a controller's torque short of the robot's reflexes: torque range, torque rate, speed and position
limits; gravity is the robot's to add. A push the rate limit cannot take back at once is judged by where it would take
the joint."""

import numpy as np
import pytest

from robot_controller.hardware.torque_guard import GuardSettings, RobotLimits, TorqueGuard, stopping_distance

N = 3
LIMITS = RobotLimits(
    torque_nm=np.array([87.0, 87.0, 12.0]),
    velocity_rad_s=np.array([2.0, 2.0, 2.5]),
    lower_rad=np.full(N, -2.0),
    upper_rad=np.full(N, 2.0),
)
PERIOD_S = 0.001
STILL = np.zeros(N)
INERTIA = np.array([0.5, 0.5, 0.2])  # kg·m²


def guard_at_rest_of(wanted, gravity=STILL):
    """A guard whose last command was ``wanted - gravity`` already (no rate limit in the way)."""
    guard = TorqueGuard(LIMITS, PERIOD_S)
    guard.last_sent = np.asarray(wanted, float) - gravity
    return guard


def test_a_torque_within_every_limit_passes_less_gravity():
    gravity = np.array([1.0, -20.0, 0.5])
    wanted = np.array([5.0, -30.0, 1.0])
    guard = guard_at_rest_of(wanted, gravity)
    sent = guard(wanted, gravity, STILL, STILL, INERTIA)
    np.testing.assert_allclose(sent, wanted - gravity)
    assert guard.acted.tolist() == [0, 0, 0]


def test_the_total_torque_is_clipped_to_the_range_and_its_change_to_the_rate():
    guard = TorqueGuard(LIMITS, PERIOD_S)  # nothing commanded before: from 0
    gravity = np.array([0.0, 10.0, 0.0])
    heavy = np.full(N, 1e6)  # kg·m²: the push moves it nowhere near a limit
    sent = guard(np.array([500.0, -500.0, 3.0]), gravity, STILL, STILL, heavy)
    settings = GuardSettings()
    step = settings.rate_share * 1.0  # of 1,000 N·m/s over 1 ms, from nothing
    np.testing.assert_allclose(sent, [step, -step, step])
    for _ in range(500):
        sent = guard(np.array([500.0, -500.0, 3.0]), gravity, STILL, STILL, heavy)
    top = settings.torque_share * 87.0
    np.testing.assert_allclose(sent + gravity, [top, -top, 3.0])  # the range is the total's
    assert guard.acted.tolist()[:2] == [501, 501]


def test_a_non_finite_torque_holds_gravity_alone():
    gravity = np.array([1.0, 2.0, 3.0])
    guard = guard_at_rest_of(gravity, gravity)
    sent = guard(np.array([np.nan, np.inf, 1.0]), gravity, STILL, STILL, INERTIA)
    assert np.isfinite(sent).all()
    np.testing.assert_allclose(sent[:2], 0.0)


@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_a_joint_headed_past_its_speed_share_is_braked_and_no_longer_pushed(direction):
    guard = TorqueGuard(LIMITS, PERIOD_S)
    allowed = GuardSettings().velocity_share * LIMITS.velocity_rad_s
    # Joint 1 just under its share with nothing pushing; joint 2 as fast, pushed at 30 N·m: the push, ramped down at
    # the rate limit, would carry it past; joint 3 at rest.
    velocity = direction * np.array([allowed[0] - 0.01, allowed[1] - 0.01, 0.0])
    guard.last_sent = direction * np.array([0.0, 30.0, 0.0])
    sent = guard(direction * np.array([0.0, 30.0, 0.0]), STILL, STILL, velocity, INERTIA)
    assert sent[0] == 0.0 and sent[2] == 0.0
    assert direction * sent[1] < 30.0  # taken back as fast as the rate allows
    assert direction * sent[1] == pytest.approx(30.0 - guard.max_step_nm)


def test_a_joint_headed_into_its_position_margin_is_braked_in_time_and_nothing_pulls_it_back():
    guard = TorqueGuard(LIMITS, PERIOD_S)
    guard.max_step_nm = np.inf  # (the rate limit aside: what the guard asks for)
    position = np.array([-1.885, 1.885, 0.0])  # 15 mm from their margins: at 1 rad/s, about what braking takes
    velocity = np.array([-1.0, 1.0, -1.0])  # joints 1 and 2 towards their limits; 3 far from both
    sent = guard(np.zeros(N), STILL, position, velocity, INERTIA)
    assert sent[0] > 0 and sent[1] < 0 and sent[2] == 0.0
    fresh = TorqueGuard(LIMITS, PERIOD_S)
    away = fresh(np.zeros(N), STILL, position, -velocity, INERTIA)  # moving away, unpushed: left alone
    np.testing.assert_allclose(away, 0.0)


def test_the_stopping_distance_and_peak_speed_of_a_push_ramped_down():
    inertia, rate = np.array([1.0]), 1000.0
    # No push: the full brake is ramped in from nothing; at 1 rad/s the joint stops within that ramp or soon after.
    distance, peak = stopping_distance(np.array([1.0]), np.array([0.0]), rate, np.array([50.0]), inertia)
    assert peak[0] == 1.0
    assert 0.0 < distance[0] < 1.0 * 0.05 + 1.0 / (2 * 50.0)  # under the ramp's time at full speed plus the brake's
    # A push of 20 N·m along the motion: 0.2 s more of acceleration at 1000 N·m/s → 0.2 rad/s more at the peak.
    distance_pushed, peak = stopping_distance(np.array([1.0]), np.array([20.0]), rate, np.array([50.0]), inertia)
    assert peak[0] == pytest.approx(1.2)
    assert distance_pushed[0] > distance[0]
    # At rest, nothing pushing: it goes nowhere.
    still, _ = stopping_distance(np.array([0.0]), np.array([0.0]), rate, np.array([50.0]), inertia)
    assert still[0] == 0.0


def test_near_a_position_limit_the_robot_s_envelope_is_the_speed_limit():
    from robot_controller.core.model.velocity_envelope import VelocityEnvelope

    envelope = VelocityEnvelope(
        max_rad_s=np.full(N, 2.6),
        offset_rad_s=np.full(N, 0.3),
        deceleration_rad_s2=np.full(N, 4.0),
        lower_rad=np.full(N, -2.0),
        upper_rad=np.full(N, 2.0),
    )
    limits = RobotLimits(LIMITS.torque_nm, LIMITS.velocity_rad_s, LIMITS.lower_rad, LIMITS.upper_rad, envelope=envelope)
    # Every joint at 1 rad/s, unpushed: far from its limits (joint 1), 0.16 rad from its upper limit heading to it
    # (joint 2: the envelope allows sqrt(2·4·0.16) − 0.3 = 0.83 rad/s there: braked), and the same heading away from
    # it (joint 3).
    position = np.array([0.0, 1.84, 1.84])
    velocity = np.array([1.0, 1.0, -1.0])
    sent = TorqueGuard(limits, PERIOD_S)(np.zeros(N), STILL, position, velocity, INERTIA)
    assert sent[0] == 0.0 and sent[2] == 0.0
    assert sent[1] < 0.0, "braked towards the limit it nears too fast for the robot"
    plain = TorqueGuard(LIMITS, PERIOD_S)(np.zeros(N), STILL, position, velocity, INERTIA)
    assert plain[1] == 0.0, "the constant limits alone let it go on"
