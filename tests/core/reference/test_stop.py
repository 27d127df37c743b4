"""The reference brought to rest within a deceleration (no ROS): a cancelled goal's stop, and the stop a trajectory
makes first when joining it directly would swing past its first point. It starts exactly on the reference in force,
comes to rest where ``rest_position`` says within ``stop_time_s``, never decelerates harder than allowed (or than it
already was), and goes one way only, then holds."""

import numpy as np
import pytest

from robot_controller.core.reference.quintic_path import QuinticPath
from robot_controller.core.reference.stop import MIN_STOP_S, overshoots, rest_position, stop_path, stop_time_s

DECELERATION = 20.0  # rad/s², the planner's default stop_deceleration


def sampled(path, after_s=0.5, count=4001):
    t = np.linspace(0.0, path.duration_s + after_s, count)
    return (t, *path.sample_many(t))


@pytest.mark.parametrize(
    "velocity",
    [[np.pi], [-np.pi], [0.3], [4.0, -1.0, 0.0], [0.0, 2.5, -2.5]],
    ids=["sine_peak_speed", "backwards", "slow", "three_joints", "one_still"],
)
@pytest.mark.parametrize("deceleration", [DECELERATION, 5.0])
def test_a_moving_reference_comes_to_rest_within_the_deceleration_going_one_way(velocity, deceleration):
    v0 = np.array(velocity)
    p0 = np.linspace(-0.4, 0.7, len(v0))
    start = (p0, v0, np.zeros_like(v0))
    path = stop_path(start, deceleration)
    t, p, v, a = sampled(path)
    for got, want in zip(path.sample(0.0), start, strict=True):  # no jump from the reference in force
        np.testing.assert_allclose(got, want, atol=1e-12)
    assert path.duration_s == pytest.approx(stop_time_s(v0, np.zeros_like(v0), deceleration))
    assert np.max(np.abs(a)) <= deceleration * (1 + 1e-9)
    # Each joint goes only the way it was going (a still one stays put), and no further than where it rests.
    steps = np.diff(p, axis=0) * np.sign(v0)
    assert np.all(steps >= -1e-12)
    np.testing.assert_allclose(p[:, v0 == 0.0], np.broadcast_to(p0[v0 == 0.0], p[:, v0 == 0.0].shape), atol=1e-12)
    rest = rest_position(start, path.duration_s)
    np.testing.assert_allclose(p[-1], rest, atol=1e-12)
    np.testing.assert_allclose(p[t >= path.duration_s], np.broadcast_to(rest, p[t >= path.duration_s].shape))
    assert np.all(v[t >= path.duration_s] == 0.0) and np.all(a[t >= path.duration_s] == 0.0)


def test_the_stop_from_the_sines_peak_speed_takes_the_time_the_deceleration_gives():
    # The default sine (1 rad, 0.5 Hz) at its peak speed, π rad/s, stopped at 20 rad/s²: 1.875·π/20 s, rest
    # π·T/2 ahead; the distance grows with the speed, and a gentler deceleration takes longer and further.
    v0 = np.array([np.pi])
    start = (np.zeros(1), v0, np.zeros(1))
    assert stop_time_s(v0, np.zeros(1), DECELERATION) == pytest.approx(1.875 * np.pi / 20)
    assert rest_position(start, stop_time_s(v0, np.zeros(1), DECELERATION))[0] == pytest.approx(0.4626, abs=1e-4)
    gentle = stop_path(start, 5.0)
    assert gentle.duration_s == pytest.approx(4 * stop_path(start, DECELERATION).duration_s)
    assert gentle.final_position[0] > stop_path(start, DECELERATION).final_position[0]


def test_a_reference_at_rest_stays_where_it_is():
    start = (np.array([0.3, -1.2]), np.zeros(2), np.zeros(2))
    path = stop_path(start, DECELERATION)
    assert path.duration_s == MIN_STOP_S
    _, p, v, a = sampled(path)
    np.testing.assert_allclose(p, np.broadcast_to(start[0], p.shape), atol=1e-15)
    assert np.all(v == 0.0) and np.all(a == 0.0)


@pytest.mark.parametrize("phase", np.linspace(0.0, 2 * np.pi, 24, endpoint=False))
def test_stopped_anywhere_on_a_sine_it_never_turns_back_nor_decelerates_harder_than_allowed_or_than_it_was(phase):
    amplitude, omega = 1.0, np.pi  # the default sine: 1 rad at 0.5 Hz (π² rad/s² at most)
    start = (
        np.array([amplitude * np.sin(phase)]),
        np.array([amplitude * omega * np.cos(phase)]),
        np.array([-amplitude * omega**2 * np.sin(phase)]),
    )
    path = stop_path(start, DECELERATION)
    _, p, v, a = sampled(path)
    for got, want in zip(path.sample(0.0)[:2], start[:2], strict=True):
        np.testing.assert_allclose(got, want, atol=1e-12)
    # The acceleration is the sine's where it drives the joint on; where it slows the joint, only as much as the stop
    # can take without turning back (at a peak, none: the stop holds where it is).
    a0, v0 = start[2][0], start[1][0]
    if a0 * v0 > 0:
        assert path.sample(0.0)[2][0] == pytest.approx(a0)
    else:
        assert abs(path.sample(0.0)[2][0]) <= abs(a0) + 1e-12
    assert np.all(v[:, 0] * v0 >= -1e-12)  # one way
    assert np.all((p[:, 0] - start[0][0]) * np.sign(v0) >= -1e-12)  # never behind where it started
    assert np.max(np.abs(a)) <= max(DECELERATION, abs(start[2][0])) * (1 + 1e-9)
    assert v[-1, 0] == 0.0 and a[-1, 0] == 0.0
    assert path.duration_s <= stop_time_s(start[1], start[2], DECELERATION) + 1e-12


def test_a_join_is_said_to_overshoot_only_when_it_goes_past_both_its_point_and_the_stop():
    start = (np.zeros(1), np.array([np.pi]), np.zeros(1))  # mid-sine, π rad/s towards the point

    def join(target, duration_s):
        return QuinticPath.through(
            np.array([0.0, duration_s]), np.array([[0.0], [target]]), np.array([[np.pi], [0.0]]), np.zeros((2, 1))
        )

    assert overshoots(join(0.5, 2.0), start, DECELERATION)  # peaks near 1.36 rad before coming back to 0.5
    assert not overshoots(join(3.0, 2.0), start, DECELERATION)  # far ahead: it never goes past it
    assert not overshoots(join(0.5, 0.25), start, DECELERATION)  # reached within the stop's own distance
    single = QuinticPath.through(np.zeros(1), np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)))
    assert not overshoots(single, start, DECELERATION)  # no segment to join


def test_a_stop_that_would_rest_beyond_the_range_rests_at_its_limit_one_way():
    # At the sine's peak speed 0.2 rad below the upper limit: at 20 rad/s² it would rest 0.46 rad on, past it.
    lower, upper = np.array([-np.pi, -1.0]), np.array([np.pi, 1.0])
    start = (np.array([np.pi - 0.2, 0.0]), np.array([np.pi, -0.5]), np.zeros(2))
    free = stop_path(start, DECELERATION)
    assert free.final_position[0] > upper[0]
    path = stop_path(start, DECELERATION, (lower, upper))
    t, p, v, a = sampled(path)
    assert path.duration_s < free.duration_s
    assert np.all(p <= upper + 1e-9) and np.all(p >= lower - 1e-9)
    assert path.final_position[0] == pytest.approx(upper[0], abs=1e-6)  # as far as it may go: no harder than needed
    assert np.all(np.diff(p[:, 0]) >= -1e-12) and np.all(np.diff(p[:, 1]) <= 1e-12)  # one way each
    for got, want in zip(path.sample(0.0), start, strict=True):
        np.testing.assert_allclose(got, want, atol=1e-12)
    # Within the range, the range changes nothing.
    inside = (np.array([0.0, 0.0]), np.array([np.pi, -0.5]), np.zeros(2))
    assert stop_path(inside, DECELERATION, (lower, upper)).duration_s == stop_path(inside, DECELERATION).duration_s
