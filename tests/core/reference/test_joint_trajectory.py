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
from robot_controller.core.reference.joint_trajectory import (
    JointTrajectory,
    Waypoints,
    blend,
    check_waypoints,
    complete_joints,
    joint_names_problem,
)
from robot_controller.core.reference.stop import rest_position, stop_time_s

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


# A goal taken mid-sine: the sine's peak speed towards a point close ahead (``goto 0.5 --time 2``).
FAST_TOWARDS = (np.zeros(1), np.array([np.pi]), np.zeros(1))
STOP_DECELERATION = 20.0  # rad/s², the planner's default


def one_point(target, time_s=2.0):
    return Waypoints(("joint1",), np.array([time_s]), np.array([[target]]), None, None)


def positions_of(trajectory, count=8001):
    t = np.linspace(0.0, trajectory.duration_s + 0.5, count)
    return t, trajectory.path.sample_many(t)[0][:, 0]


def test_a_fast_start_close_to_the_point_stops_first_instead_of_swinging_past_it():
    direct = blend(one_point(0.5), FAST_TOWARDS)
    assert isinstance(direct, JointTrajectory) and direct.stop_first_s == 0.0
    assert positions_of(direct)[1].max() > 1.3  # joined directly: up to 1.36 rad and back to 0.5
    trajectory = blend(one_point(0.5), FAST_TOWARDS, stop_deceleration=STOP_DECELERATION)
    assert isinstance(trajectory, JointTrajectory)
    assert trajectory.stop_first_s == pytest.approx(stop_time_s(np.array([np.pi]), np.zeros(1), STOP_DECELERATION))
    for got, want in zip(trajectory.sample(0.0), FAST_TOWARDS, strict=True):  # from the reference in force
        np.testing.assert_allclose(got, want, atol=1e-12)
    t, p = positions_of(trajectory)
    assert p.max() <= 0.5 + 1e-9  # never past the point
    assert np.all(np.diff(p) >= -1e-12)  # on one way: no swing back either
    # The point is reached stop_first_s later than its time_from_start, at rest, and held.
    assert trajectory.duration_s == pytest.approx(trajectory.stop_first_s + 2.0)
    p_end, v_end, a_end = trajectory.sample(trajectory.stop_first_s + 2.0)
    assert p_end.tolist() == [0.5] and v_end.tolist() == [0.0] and a_end.tolist() == [0.0]
    accelerations = trajectory.path.sample_many(t[t <= trajectory.stop_first_s])[2]
    assert np.max(np.abs(accelerations)) <= STOP_DECELERATION * (1 + 1e-9)  # the stop within its deceleration


def test_a_start_moving_away_from_the_point_turns_back_no_further_than_its_stop():
    away = (np.zeros(1), np.array([-np.pi]), np.zeros(1))
    direct = blend(one_point(0.5), away)
    trajectory = blend(one_point(0.5), away, stop_deceleration=STOP_DECELERATION)
    stop_s = stop_time_s(away[1], away[2], STOP_DECELERATION)
    rest = rest_position(away, stop_s)[0]  # -0.46 rad: where stopping at once rests
    assert positions_of(direct)[1].min() < rest - 0.5  # joined directly it carried on to -1.15 rad
    assert trajectory.stop_first_s == pytest.approx(stop_s)
    _, p = positions_of(trajectory)
    assert p.min() >= rest - 1e-9 and p.max() <= 0.5 + 1e-9
    np.testing.assert_allclose(trajectory.sample(stop_s + 2.0)[0], [0.5])


@pytest.mark.parametrize(
    "start",
    [AT_REST, (np.zeros(1), np.array([0.3]), np.zeros(1)), MOVING],
    ids=["at_rest", "slowly_towards", "mid_sine_far_point"],
)
def test_a_join_that_does_not_swing_past_its_point_is_the_direct_one(start):
    waypoints = one_point(2.0, 3.0)
    direct = blend(waypoints, start)
    trajectory = blend(waypoints, start, stop_deceleration=STOP_DECELERATION)
    assert trajectory.stop_first_s == 0.0
    np.testing.assert_array_equal(trajectory.path.times_s, direct.path.times_s)
    np.testing.assert_array_equal(trajectory.path.coefficients, direct.path.coefficients)


def test_the_planner_takes_a_goal_sent_mid_sine_with_the_stop_first(arm):
    accepted = taken(arm, ["joint1"], [2.0], [[0.5]], start=FAST_TOWARDS, stop_deceleration=STOP_DECELERATION)
    trajectory = accepted.trajectory
    assert trajectory.stop_first_s > 0.0
    assert positions_of(trajectory)[1].max() <= 0.5 + 1e-9


def test_joint_names_are_each_the_arms_once_and_all_of_them_unless_partial_goals_are_allowed():
    arm = ["shoulder", "elbow", "wrist"]
    assert joint_names_problem(["wrist", "shoulder", "elbow"], arm) is None  # any order
    assert joint_names_problem(["elbow"], arm) == (
        "missing joint(s) ['shoulder', 'wrist']: a trajectory gives every joint of the arm "
        "['shoulder', 'elbow', 'wrist']"
    )
    assert joint_names_problem(["elbow"], arm, allow_partial=True) is None
    assert joint_names_problem(["elbow", "knee"], arm, allow_partial=True) == (
        "unknown joint(s) ['knee']: the arm's joints are ['shoulder', 'elbow', 'wrist']"
    )
    assert joint_names_problem(["elbow", "elbow"], arm, allow_partial=True) == "joint 'elbow' is named more than once"
    assert joint_names_problem([], arm, allow_partial=True) == "no joint names"


def test_a_partial_trajectory_holds_the_other_joints_where_the_reference_is():
    arm = ("shoulder", "elbow", "wrist")
    hold = np.array([0.1, -0.2, 0.3])
    names, positions, velocities, accelerations = complete_joints(
        ["wrist"], arm, hold, [[0.5], [0.7]], [[0.4], [0.0]], [[], []]
    )
    assert names == ["wrist", "shoulder", "elbow"]
    assert positions == [[0.5, 0.1, -0.2], [0.7, 0.1, -0.2]]
    assert velocities == [[0.4, 0.0, 0.0], [0.0, 0.0, 0.0]]  # the held joints at rest
    assert accelerations == [[], []]  # none given: still none
    # Put in the arm's order by the check, as any full trajectory is.
    waypoints = check_waypoints(names, [1.0, 2.0], positions, velocities, accelerations, JointLimits.unlimited(arm))
    assert isinstance(waypoints, Waypoints), waypoints
    np.testing.assert_array_equal(waypoints.positions, [[0.1, -0.2, 0.5], [0.1, -0.2, 0.7]])
    np.testing.assert_array_equal(waypoints.velocities, [[0.0, 0.0, 0.4], [0.0, 0.0, 0.0]])
    assert waypoints.accelerations is None
