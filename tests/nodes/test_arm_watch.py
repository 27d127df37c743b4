"""What a FollowJointTrajectory goal hears of the arm (``nodes.trajectory_planner.arm_watch``), fed messages by hand on
a planner's clock that the test moves: the controller's state is stale only after a few of its periods at two checks
in a row, the brakes and the controller's faults end a goal with the reason, the world's start brakes in lockstep do
not. No ROS graph: the messages are built and handed to the callbacks as the executor would."""

import numpy as np
import pytest
from std_msgs.msg import Bool, Float64MultiArray, MultiArrayDimension

from robot_controller.core.controller import state_layout
from robot_controller.nodes.trajectory_planner.arm_watch import FIRST_HEARD_S, STALE_PERIODS, ArmWatch
from robot_controller.ros.messages import brakes_label

PERIOD_S = 0.01  # the controller's, 100 Hz


class Planner:
    """What the watch uses of the planner: its clock, parameters and subscriptions."""

    def __init__(self, lockstep: bool = True) -> None:
        self.time_s = 0.0
        self.params = {"publish_rate_hz": 100.0, "lockstep": lockstep}
        self.subscriptions = 0

    def now_s(self) -> float:
        return self.time_s

    def create_subscription(self, *_args):
        self.subscriptions += 1
        return object()

    def destroy_subscription(self, _subscription) -> None:
        self.subscriptions -= 1


def state(time_s: float, status: str = "ok") -> Float64MultiArray:
    values = {name: np.zeros(1) for name in state_layout.FIELDS}
    return Float64MultiArray(data=state_layout.encode(time_s, status, time_s, 1, values))


def brakes(engaged: bool, *reasons: str) -> Float64MultiArray:
    msg = Float64MultiArray(data=[1.0 if engaged else 0.0])
    msg.layout.dim = [MultiArrayDimension(label=brakes_label(set(reasons)), size=1, stride=1)]
    return msg


@pytest.fixture
def watched():
    planner = Planner()
    watch = ArmWatch(planner, ["joint1"])
    watch.listen(True)
    watch.new_goal()
    for k in range(30):  # the controller ticks at 100 Hz, heard as it ticks
        planner.time_s = k * PERIOD_S
        watch.controller_state(state(planner.time_s))
        assert watch.fault(planner.time_s) is None
    return planner, watch


def test_the_controllers_state_goes_stale_after_a_few_of_its_periods_at_two_checks(watched):
    planner, watch = watched
    heard_s = planner.time_s
    assert watch.stale_after_s() == pytest.approx(STALE_PERIODS * PERIOD_S)
    planner.time_s = heard_s + STALE_PERIODS * PERIOD_S + 0.005
    assert watch.fault(planner.time_s) is None and not watch.fresh(planner.time_s)  # once: maybe the planner's delay
    planner.time_s += PERIOD_S
    reason = watch.fault(planner.time_s)
    assert (
        reason
        == "the controller's state (/controller/state) is stale: none for 0.065 s, over 0.050 s (5 control periods)"
    )
    watch.controller_state(state(planner.time_s))  # it speaks again: fresh at once
    assert watch.fault(planner.time_s) is None and watch.fresh(planner.time_s)


def test_a_late_check_that_then_hears_the_state_is_not_stale(watched):
    planner, watch = watched
    planner.time_s += 0.2  # the planner's executor held up: the state waiting in its queue is taken next
    assert watch.fault(planner.time_s) is None
    watch.controller_state(state(planner.time_s - 0.001))
    planner.time_s += PERIOD_S
    assert watch.fault(planner.time_s) is None


def test_brakes_and_faults_end_the_goal_with_the_reason(watched):
    planner, watch = watched
    watch.brakes_callback(brakes(True, "start"))  # the lockstep world's start: released by the first effort
    assert watch.fault(planner.time_s) is None
    watch.brakes_callback(brakes(True, "drive_timeout"))
    assert watch.fault(planner.time_s) == (
        "the arm's brakes engaged (drive_timeout): the arm is not following the trajectory"
    )
    watch.brakes_callback(brakes(False))  # released before the planner looked: the arm stood braked all the same
    assert "brakes engaged (drive_timeout)" in watch.fault(planner.time_s)
    watch.new_goal()  # the next goal is judged on its own time
    assert watch.fault(planner.time_s) is None
    watch.controller_state(state(planner.time_s, "law_fault"))
    assert watch.fault(planner.time_s) == "the controller reports law_fault: the loop stops"
    watch.estop_callback(Bool(data=True))
    assert watch.fault(planner.time_s) == "e-stop: the arm is braked"


def test_on_the_wall_clock_the_start_brakes_count_too():
    planner = Planner(lockstep=False)
    watch = ArmWatch(planner, ["joint1"])
    watch.listen(True)
    watch.brakes_callback(brakes(True, "start"))
    watch.new_goal()  # one that starts while the brakes hold ends at once
    assert "brakes engaged (start)" in watch.fault(0.0)


def test_an_arm_never_heard_ends_the_goal_after_a_while_and_listening_again_forgets():
    planner = Planner()
    watch = ArmWatch(planner, ["joint1"])
    watch.listen(True)
    assert planner.subscriptions == 4  # the e-stop's and the brakes', always; the arm's two while a goal is in force
    assert watch.fault(FIRST_HEARD_S) is None
    assert watch.fault(FIRST_HEARD_S + 0.01) == "nothing heard of the arm in 3.01 s"
    watch.controller_state(state(0.0))
    watch.listen(False)
    assert planner.subscriptions == 2 and watch.estimate is None
