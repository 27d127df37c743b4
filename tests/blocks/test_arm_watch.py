"""What a FollowJointTrajectory goal hears of the arm (``blocks.arm_watch``), fed values by hand on a planner's clock
that the test moves: the controller's state is stale only after a few of its periods at two checks in a row, the
brakes and the controller's faults end a goal with the reason, the world's start brakes where the world waits do
not. No ROS."""

import numpy as np
import pytest

from robot_controller.blocks.arm_watch import FIRST_HEARD_S, STALE_PERIODS, ArmWatch
from robot_controller.blocks.values import Array, JointSample, brakes_label
from robot_controller.core.controller import state_layout

PERIOD_S = 0.01  # the controller's, 100 Hz; the planner's too


def state(time_s: float, status: str = "ok") -> Array:
    values = {name: np.zeros(1) for name in state_layout.FIELDS}
    return Array(np.asarray(state_layout.encode(time_s, status, time_s, 1, values), dtype=float))


def brakes(engaged: bool, *reasons: str) -> Array:
    return Array(np.array([1.0 if engaged else 0.0]), brakes_label(set(reasons)))


def watch(world_waits: bool = True) -> ArmWatch:
    return ArmWatch(["joint1"], PERIOD_S, world_waits=world_waits)


@pytest.fixture
def watched():
    arm = watch()
    arm.new_goal()
    for k in range(30):  # the controller ticks at 100 Hz, heard as it ticks
        arm.take("state", state(k * PERIOD_S), k * PERIOD_S)
        assert arm.fault(k * PERIOD_S) is None
    return arm, 29 * PERIOD_S


def test_the_controllers_state_goes_stale_after_a_few_of_its_periods_at_two_checks(watched):
    arm, heard_s = watched
    assert arm.stale_after_s() == pytest.approx(STALE_PERIODS * PERIOD_S)
    now_s = heard_s + STALE_PERIODS * PERIOD_S + 0.005
    assert arm.fault(now_s) is None and not arm.fresh(now_s)  # once: maybe the planner's delay
    now_s += PERIOD_S
    reason = arm.fault(now_s)
    assert (
        reason
        == "the controller's state (/controller/state) is stale: none for 0.065 s, over 0.050 s (5 control periods)"
    )
    arm.take("state", state(now_s), now_s)  # it speaks again: fresh at once
    assert arm.fault(now_s) is None and arm.fresh(now_s)


def test_a_late_check_that_then_hears_the_state_is_not_stale(watched):
    arm, now_s = watched
    now_s += 0.2  # the planner held up: the state waiting in its queue is taken next
    assert arm.fault(now_s) is None
    arm.take("state", state(now_s - 0.001), now_s)
    now_s += PERIOD_S
    assert arm.fault(now_s) is None


def test_brakes_and_faults_end_the_goal_with_the_reason(watched):
    arm, now_s = watched
    arm.take("brakes", brakes(True, "start"), now_s)  # the world's start: released by the first effort
    assert arm.fault(now_s) is None
    arm.take("brakes", brakes(True, "drive_timeout"), now_s)
    assert arm.fault(now_s) == "the arm's brakes engaged (drive_timeout): the arm is not following the trajectory"
    arm.take("brakes", brakes(False), now_s)  # released before the planner looked: the arm stood braked all the same
    assert "brakes engaged (drive_timeout)" in arm.fault(now_s)
    arm.new_goal()  # the next goal is judged on its own time
    assert arm.fault(now_s) is None
    arm.take("state", state(now_s, "law_fault"), now_s)
    assert arm.fault(now_s) == "the controller reports law_fault: the loop stops"
    arm.take("estop", True, now_s)
    assert arm.fault(now_s) == "e-stop: the arm is braked"


def test_where_the_world_does_not_wait_the_start_brakes_count_too():
    arm = watch(world_waits=False)
    arm.take("brakes", brakes(True, "start"), 0.0)
    arm.new_goal()  # one that starts while the brakes hold ends at once
    assert "brakes engaged (start)" in arm.fault(0.0)


def test_an_arm_never_heard_ends_the_goal_after_a_while_and_forgetting_starts_over():
    arm = watch()
    assert arm.fault(FIRST_HEARD_S) is None
    assert arm.fault(FIRST_HEARD_S + 0.01) == "nothing heard of the arm in 3.01 s"
    arm.take("state", state(0.0), 0.0)
    arm.forget(5.0)
    assert arm.estimate is None and arm.fault(5.0 + FIRST_HEARD_S) is None


def test_readings_judge_a_controller_that_publishes_no_state_in_the_arms_joint_order():
    arm = ArmWatch(["a", "b"], PERIOD_S, world_waits=True)
    arm.take("reading", JointSample(0.0, ["b", "a"], np.array([2.0, 1.0]), np.array([0.2, 0.1])), 0.5)
    assert arm.measured[0] == 0.5 and arm.measured[1].tolist() == [1.0, 2.0] and arm.measured[2].tolist() == [0.1, 0.2]
    arm.take("reading", JointSample(0.0, ["a"], np.array([9.0]), np.array([0.0])), 0.6)  # a joint missing: ignored
    assert arm.measured[0] == 0.5 and arm.fresh(0.5 + 2 * PERIOD_S)
    assert arm.fault(0.7) is None  # stale at one check only
    assert (
        arm.fault(0.71)
        == "the arm's readings (/joint_states) is stale: none for 0.210 s, over 0.050 s (5 control periods)"
    )
