"""Live changes of the planner's motion blended (no ROS): continuous from the reference in force,
within the range both motions keep, and long enough for the torque the arm has."""

import numpy as np
import pytest

from robot_controller import resources
from robot_controller.core.model import ArmDynamics
from robot_controller.core.reference import Crossfade, crossfade, make_trajectory
from robot_controller.core.reference.crossfade import MIN_CROSSFADE_S


def motion(**shape):
    trajectory = make_trajectory("sine", joint_count=1, **shape)
    return lambda time_s: trajectory.sample(time_s)


OLD = motion(amplitude=1.0, frequency_hz=0.5)
NEW = motion(amplitude=0.3, offset=2.5, frequency_hz=2.0)  # elsewhere, faster: a jump if switched at once


def test_the_blend_starts_on_the_old_motion_ends_on_the_new_and_never_jumps():
    blend = Crossfade(OLD, NEW, start_s=3.3, duration_s=1.0)
    for got, want in zip(blend.at(3.3), OLD(3.3), strict=True):
        assert got == pytest.approx(want)
    for got, want in zip(blend.at(4.3), NEW(4.3), strict=True):
        assert got == pytest.approx(want)
    t = np.arange(3.0, 4.6, 1e-4)
    p, v, a = (np.array([blend.at(s)[i][0] for s in t]) for i in range(3))
    assert np.max(np.abs(np.diff(p))) < 2e-3  # 0.1 ms steps: no jump in position, velocity or acceleration
    assert np.max(np.abs(np.diff(v))) < 0.02 and np.max(np.abs(np.diff(a))) < 0.2
    assert np.max(np.abs(np.gradient(p, t) - v)[5:-5]) < 1e-2  # the velocity is the position's
    assert p.min() >= -1.0 - 1e-9 and p.max() <= 2.8 + 1e-9  # within what either motion reaches


def test_a_tight_torque_limit_lengthens_the_blend():
    arm = ArmDynamics(resources.default_urdf())
    roomy = crossfade(OLD, NEW, 3.3, arm, np.array([1e6]), np.array([np.inf]))
    assert roomy.duration_s == MIN_CROSSFADE_S
    tight = crossfade(OLD, NEW, 3.3, arm, np.array([8.0]), np.array([np.inf]))
    assert tight.duration_s > MIN_CROSSFADE_S
    t = np.linspace(3.3, 3.3 + tight.duration_s, 400)
    need = max(abs(arm.torque(*tight.at(s))[0]) for s in t)
    own = max(max(abs(arm.torque(*OLD(s))[0]), abs(arm.torque(*NEW(s))[0])) for s in t)
    assert need <= max(8.0, own) * 1.05  # sampled more finely than the check: within a few %
