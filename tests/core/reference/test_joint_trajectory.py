"""Joint trajectories as JTC takes them (no ROS): checked against the arm,
blended from the reference in force, interpolated smoothly through the points
and held at the last; every refusal is one line naming what is wrong."""

import numpy as np
import pytest

from robot_controller import resources
from robot_controller.core.model import ArmDynamics, JointLimits, joint_limits, urdf_velocity_limits
from robot_controller.core.reference import (
    MAX_START_DELAY_S,
    START_TOLERANCE_RAD,
    Accepted,
    accept_joint_trajectory,
    start_delay,
)

AT_REST = (np.zeros(1), np.zeros(1), np.zeros(1))
MOVING = (np.array([0.3]), np.array([1.5]), np.array([-4.0]))  # the reference in force, mid-sine


@pytest.fixture(scope="module")
def arm():
    urdf = resources.default_urdf()
    return joint_limits(urdf), ArmDynamics(urdf)


def take(arm, names, times, positions, velocities=None, accelerations=None, *, start=AT_REST, **kwargs):
    limits, dynamics = arm
    kwargs.setdefault("limits", limits)
    result = accept_joint_trajectory(
        names,
        times,
        positions,
        velocities or [[] for _ in times],
        accelerations or [[] for _ in times],
        start=start,
        dynamics=dynamics,
        torque_limit_nm=np.array([10.0]),
        margin=0.2,
        **kwargs,
    )
    return result


def taken(*args, **kwargs) -> Accepted:
    result = take(*args, **kwargs)
    assert isinstance(result, Accepted), result
    return result


class TwoJointModel:
    """I·q̈ per joint, no gravity: enough to check reordering by name."""

    joint_names = ["shoulder", "elbow"]

    def torque(self, position, velocity, acceleration):
        return np.array([0.5, 0.1]) * acceleration


def test_urdf_limits_positions_through_mujoco_and_velocities_from_the_xml(tmp_path):
    limits = joint_limits(resources.default_urdf())
    assert limits.joint_names == ("joint1",)
    assert limits.lower[0] == pytest.approx(-3.14159) and limits.upper[0] == pytest.approx(3.14159)
    assert limits.velocity.tolist() == [20.0]
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(
        '<robot name="r"><joint name="a" type="revolute"><limit lower="-1" upper="1" effort="5" velocity="2.5"/>'
        '</joint><joint name="b" type="continuous"/></robot>'
    )
    assert urdf_velocity_limits(urdf, ["b", "a", "c"]).tolist() == [np.inf, 2.5, np.inf]  # none given: unlimited


@pytest.mark.parametrize("start", [AT_REST, MOVING], ids=["at_rest", "moving"])
@pytest.mark.parametrize("given", ["positions", "velocities", "accelerations"])
def test_passes_through_the_points_smoothly_from_the_reference_and_holds_the_last(arm, start, given):
    times = [1.0, 1.8, 3.0]
    positions = [[0.8], [0.2], [-0.5]]
    velocities = [[0.0], [-0.9], [0.0]] if given != "positions" else None
    accelerations = [[-1.0], [0.5], [0.0]] if given == "accelerations" else None
    trajectory = taken(arm, ["joint1"], times, positions, velocities, accelerations, start=start).trajectory
    # The blend starts exactly at the reference in force: position, velocity and acceleration.
    for got, want in zip(trajectory.sample(0.0), start, strict=True):
        np.testing.assert_allclose(got, want, atol=1e-12)
    for k, t in enumerate(times):
        p, v, a = trajectory.sample(t)
        np.testing.assert_allclose(p, positions[k], atol=1e-12)
        if velocities is not None:
            np.testing.assert_allclose(v, velocities[k], atol=1e-9)
        if accelerations is not None:
            np.testing.assert_allclose(a, accelerations[k], atol=1e-9)
    # Continuous in position, velocity and acceleration at every knot (and at the end, into the hold).
    for t in [*times]:
        before, after = trajectory.sample(t - 1e-7), trajectory.sample(t + 1e-7)
        for left, right, tolerance in zip(before, after, (1e-6, 1e-5, 1e-3), strict=True):
            np.testing.assert_allclose(left, right, atol=tolerance)
    assert trajectory.duration_s == pytest.approx(3.0)
    p, v, a = trajectory.sample(10.0)
    assert p.tolist() == [-0.5] and v.tolist() == [0.0] and a.tolist() == [0.0]


def test_positions_only_points_in_one_direction_give_a_monotone_path(arm):
    trajectory = taken(arm, ["joint1"], [0.5, 1.0, 1.5, 2.5], [[0.1], [0.5], [0.6], [1.2]]).trajectory
    positions = np.array([trajectory.sample(t)[0][0] for t in np.linspace(0.0, 3.0, 3001)])
    assert np.all(np.diff(positions) >= -1e-12)  # no swing back past a point
    assert positions.max() == pytest.approx(1.2)


def test_joints_in_any_order_are_put_in_the_arms_order():
    limits = JointLimits.unlimited(["shoulder", "elbow"])
    result = accept_joint_trajectory(
        ["elbow", "shoulder"],
        [1.0],
        [[0.2, -0.4]],
        [[]],
        [[]],
        start=(np.zeros(2), np.zeros(2), np.zeros(2)),
        limits=limits,
        dynamics=TwoJointModel(),
        torque_limit_nm=np.array([10.0, 10.0]),
        margin=0.2,
    )
    assert isinstance(result, Accepted), result
    np.testing.assert_allclose(result.trajectory.final_position, [-0.4, 0.2])


def test_a_start_delay_counts_the_points_from_the_stamp(arm):
    trajectory = taken(arm, ["joint1"], [1.0], [[0.5]], start_delay_s=0.5).trajectory
    assert trajectory.duration_s == pytest.approx(1.5)
    np.testing.assert_allclose(trajectory.sample(1.5)[0], [0.5])
    assert start_delay(0.0, 100.0) == 0.0  # no stamp: from receipt
    assert start_delay(99.0, 100.0) == 0.0  # in the past: from receipt
    assert start_delay(100.25, 100.0) == pytest.approx(0.25)  # in the future: from the stamp
    assert "ahead of the planner's clock" in start_delay(100.0 + MAX_START_DELAY_S + 1.0, 100.0)


def test_a_first_point_at_time_0_is_the_reference_in_force(arm):
    near = START_TOLERANCE_RAD / 2
    trajectory = taken(arm, ["joint1"], [0.0, 1.0], [[0.3 + near], [0.6]], start=MOVING).trajectory
    for got, want in zip(trajectory.sample(0.0), MOVING, strict=True):  # no jump to the point
        np.testing.assert_allclose(got, want, atol=1e-12)
    np.testing.assert_allclose(trajectory.sample(1.0)[0], [0.6])
    assert isinstance(taken(arm, ["joint1"], [0.0], [[near]]), Accepted)  # at rest: hold it


@pytest.mark.parametrize(
    ("names", "times", "positions", "velocities", "accelerations", "reason"),
    [
        (["elbow"], [1.0], [[0.5]], None, None, "unknown joint(s) ['elbow']: the arm's joints are ['joint1']"),
        ([], [1.0], [[]], None, None, "missing joint(s) ['joint1']"),
        (["joint1", "joint1"], [1.0], [[0.5, 0.5]], None, None, "joint 'joint1' is named more than once"),
        (["joint1"], [], [], None, None, "no points"),
        (["joint1"], [1.0, 1.0], [[0.5], [0.6]], None, None, "points[1]: time_from_start 1 s is not after points[0]'s"),
        (["joint1"], [-1.0], [[0.5]], None, None, "points[0]: time_from_start -1 s is negative"),
        (["joint1"], [float("nan")], [[0.5]], None, None, "points[0]: time_from_start is not finite"),
        (["joint1"], [1.0], [[0.5, 0.2]], None, None, "points[0]: 2 positions for 1 joint(s)"),
        (["joint1"], [1.0], [[]], None, None, "points[0] has no positions"),
        (["joint1"], [1.0, 2.0], [[0.5], [0.6]], [[0.1], []], None, "points[1] has no velocities but other points"),
        (["joint1"], [1.0], [[float("inf")]], None, None, "points[0]: positions of joint1 is not finite"),
        (["joint1"], [1.0], [[3.5]], None, None, "points[0]: joint1 position 3.5 rad is above its upper limit 3.14159"),
        (["joint1"], [1.0], [[-3.5]], None, None, "joint1 position -3.5 rad is below its lower limit -3.14159"),
        (
            ["joint1"],
            [1.0, 2.0],
            [[0.5], [0.6]],
            [[25.0], [0.0]],
            None,
            "points[0]: joint1 velocity 25 rad/s is beyond its limit ±20 rad/s",
        ),
        (["joint1"], [1.0], [[0.5]], [[0.5]], None, "points[0] (the last): joint1 velocity 0.5 rad/s must be 0"),
        (["joint1"], [1.0], [[0.5]], None, [[2.0]], "points[0] (the last): joint1 acceleration 2 rad/s² must be 0"),
        (["joint1"], [0.0], [[0.5]], None, None, "points[0] is at time 0 but 0.5 rad from the reference in force"),
        (
            ["joint1"],
            [1.0, 2.0],
            [[3.1], [3.0]],
            [[3.0], [0.0]],
            None,
            "reaches 3.673 rad, above its upper limit 3.14159 rad on joint1 1.32 s in",  # swings past it
        ),
        (["joint1"], [0.15], [[1.0]], None, None, "the trajectory needs"),
    ],
)
def test_each_refusal_is_one_line_with_the_reason(arm, names, times, positions, velocities, accelerations, reason):
    result = take(arm, names, times, positions, velocities, accelerations)
    assert isinstance(result, str) and reason in result, result
    assert "\n" not in result


def test_the_path_is_checked_against_the_velocity_limit_between_the_points(arm):
    limits = JointLimits(("joint1",), np.array([-3.0]), np.array([3.0]), np.array([1.0]))
    # A quintic from rest to rest peaks at 1.875 × the mean speed: 1.875 rad/s here.
    result = take(arm, ["joint1"], [1.0], [[1.0]], limits=limits)
    assert isinstance(result, str)
    assert result.startswith("the path between the points reaches 1.875 rad/s, beyond its velocity limit ±1 rad/s")
    assert isinstance(take(arm, ["joint1"], [2.0], [[1.0]], limits=limits), Accepted)


def test_an_infeasible_path_names_joint_and_numbers_and_is_taken_only_when_told(arm):
    refused = take(arm, ["joint1"], [0.15], [[1.0]])  # 256 rad/s² at its peak: about 21 N·m
    assert refused.startswith("the trajectory needs ") and " N·m on joint1 (" in refused
    assert refused.endswith(
        "against 8.0 N·m usable (10.0 N·m limit, 20 % kept for feedback): give its points more time"
    ), refused
    warned = taken(arm, ["joint1"], [0.15], [[1.0]], torque_policy="warn")
    assert warned.warning is not None and warned.peak_torque_nm[0] > 8.0
    assert taken(arm, ["joint1"], [3.0], [[3.0]]).warning is None


def test_too_many_points_are_refused_before_any_maths(arm):
    times = np.linspace(0.01, 100.0, 501).tolist()
    result = take(arm, ["joint1"], times, [[0.1]] * 501)
    assert result == "501 points, more than the 500 taken"
