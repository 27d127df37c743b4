"""Trajectories: values, self-consistency, the shaped step, refused settings (no ROS)."""

import math

import numpy as np
import pytest

from robot_controller.core.errors import ConfigError
from robot_controller.core.reference import MODES, make_trajectory


@pytest.mark.parametrize("mode", [m for m in MODES if m in ("sine", "chirp")])
def test_smooth_trajectories_are_self_consistent(mode):
    traj = make_trajectory(mode, joint_count=2, amplitude=[1.0, 0.5], frequency_hz=0.5)
    h = 1e-5
    for t in (0.3, 1.7, 4.2):
        p0, v0, a0 = traj.sample(t - h)
        p1, v1, a1 = traj.sample(t + h)
        _, v, a = traj.sample(t)
        np.testing.assert_allclose((p1 - p0) / (2 * h), v, atol=1e-4)
        np.testing.assert_allclose((v1 - v0) / (2 * h), a, atol=1e-3)


def test_sine_reference_values():
    p, v, a = make_trajectory("sine", joint_count=1, amplitude=1.0, frequency_hz=0.5).sample(0.5)
    assert p[0] == pytest.approx(1.0) and v[0] == pytest.approx(0.0, abs=1e-12)
    assert a[0] == pytest.approx(-(np.pi**2))


def test_step_square_hold():
    step = make_trajectory("step", joint_count=1, amplitude=0.5, step_time_s=1.0)
    assert step.sample(0.99)[0][0] == 0.0 and step.sample(1.0)[0][0] == 0.5
    square = make_trajectory("square", joint_count=1, amplitude=0.3, frequency_hz=1.0)
    assert square.sample(0.25)[0][0] == 0.3 and square.sample(0.75)[0][0] == -0.3
    assert make_trajectory("hold", joint_count=1, offset=0.2).sample(7.0)[0][0] == 0.2


@pytest.mark.parametrize(
    "kwargs, key",
    [
        (dict(mode="zigzag"), "mode"),
        (dict(amplitude=[1, 2, 3]), "amplitude"),
        (dict(frequency_hz=float("nan")), "frequency_hz"),
    ],
)
def test_bad_trajectory_names_the_key(kwargs, key):
    args = dict(mode="sine", joint_count=2) | kwargs
    with pytest.raises(ConfigError, match=key):
        make_trajectory(args.pop("mode"), **args)


def test_min_time_step_reaches_the_target_within_the_acceleration_limit():
    traj = make_trajectory(
        "step", joint_count=1, amplitude=0.5, step_time_s=1.0, step_shaping="min_time", max_acceleration=50.0
    )
    duration = 2 * np.sqrt(0.5 / 50.0)
    assert traj.sample(0.9)[0][0] == 0.0
    assert traj.sample(1.0 + duration / 2)[0][0] == pytest.approx(0.25)
    p, v, a = traj.sample(1.0 + duration + 1e-9)
    assert p[0] == pytest.approx(0.5) and v[0] == pytest.approx(0.0, abs=1e-6) and a[0] == 0.0
    times = np.linspace(0.9, 1.5, 6001)
    samples = np.array([traj.sample(t) for t in times])[:, :, 0]
    assert np.max(np.abs(samples[:, 2])) <= 50.0 and np.all(np.diff(samples[:, 0]) >= -1e-12)
    np.testing.assert_allclose(np.gradient(samples[:, 0], times), samples[:, 1], atol=0.05)


@pytest.mark.parametrize("ulps", [-1, 0, 1])
@pytest.mark.parametrize("instant_s, acceleration", [(0.5, 50.0), (0.6, -50.0), (0.7, 0.0)])
def test_a_shaped_step_sampled_at_a_switch_gives_the_acceleration_of_the_period_after(instant_s, acceleration, ulps):
    # 0.5 rad at 0.5 s on the 10 ms grid: up over [0.5, 0.6), down over [0.6, 0.7). Two clocks reach an instant an ulp
    # apart, and the torque held over the period after must be the same.
    traj = make_trajectory(
        "step", joint_count=1, amplitude=0.5, step_time_s=0.5, step_shaping="min_time", sample_period_s=0.01
    )
    t = instant_s
    for _ in range(abs(ulps)):
        t = math.nextafter(t, math.copysign(math.inf, ulps))
    assert traj.sample(t)[2][0] == pytest.approx(acceleration)


def test_a_shaped_step_switches_alike_on_either_clocks_time():
    traj = make_trajectory(
        "step", joint_count=1, amplitude=0.5, step_time_s=0.5, step_shaping="min_time", sample_period_s=0.01
    )
    # The in-process loop's tick 60; the graph planner's sample for the tick after its clock's 0.59 s (ns stamps).
    clock_s, previous_s = 590_000_000 * 1e-9, 580_000_000 * 1e-9
    in_process, graph = 60 * 0.01, clock_s + (clock_s - previous_s)
    assert in_process - 0.5 < 0.1 < graph - 0.5  # an ulp either side of the switch, 0.1 s into the move
    assert traj.sample(in_process)[2][0] == traj.sample(graph)[2][0] == pytest.approx(-50.0)


def test_a_jump_step_sampled_an_ulp_before_its_instant_has_stepped():
    step = make_trajectory("step", joint_count=1, amplitude=0.5, step_time_s=0.3)
    assert step.sample(math.nextafter(0.3, 0.0))[0][0] == 0.5 and step.sample(0.29)[0][0] == 0.0
