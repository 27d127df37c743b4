"""The planner's FollowJointTrajectory action server, ``/<controller_name>/follow_joint_trajectory``, served as
ros2_controllers' JointTrajectoryController serves it, so MoveIt and any action client can drive the arm.

A goal's trajectory is checked and joined onto the reference in force as a trajectory on the topic is (the planner's
``take_trajectory``); one that cannot be taken ends at once, aborted with JTC's error code (``INVALID_JOINTS``,
``OLD_HEADER_TIMESTAMP``, ``INVALID_GOAL``) and the reason, and the motion in force goes on. A taken goal preempts the
one in force (aborted: "preempted"). At every tick the goal's feedback carries desired, actual and error, and its
tolerances are checked (``core.reference.tolerances``): outside a path tolerance, or not within the goal tolerance in
time, the goal aborts and the reference stops (``stop_deceleration``) and holds. A cancel stops and holds the same
way, and the goal ends CANCELED once the reference is at rest. An e-stop, or the controller reporting a fault, aborts
the goal with the reason.

"Actual" is the controller's estimate on ``/controller/state`` (the measurement its law closes on: the noisy sensor's
``/joint_states`` would trip a tight tolerance on noise alone), with the reference it was compared with at that tick;
a controller that publishes none (the tutorial's) is judged on ``/joint_states``. Velocities are ``/joint_states``'.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.task import Future
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64MultiArray
from trajectory_msgs.msg import JointTrajectoryPoint

from robot_controller.core.controller import state_layout
from robot_controller.core.reference.tolerances import (
    GOAL_TOLERANCE_VIOLATED,
    INVALID_GOAL,
    PATH_TOLERANCE_VIOLATED,
    SUCCESSFUL,
    Tolerances,
    goal_tolerances,
)
from robot_controller.ros.qos import ESTOP_QOS, LATEST_QOS
from robot_controller.ros.stack_node import StackNode

#: Controller states that end a goal: the loop is stopping or stopped, whatever the reference does.
FAULT_STATES = frozenset(
    ("watchdog", "sensor_lost", "reference_lost", "stopped", "law_fault", "law_stopped", "late", "late_stopped")
)
_STATUS_NAMES = {code: name for name, code in state_layout.STATUS_CODES.items()}


def _action_type():
    from control_msgs.action import FollowJointTrajectory  # built at install (Makefile: control_msgs)

    return FollowJointTrajectory


@dataclass
class ActiveGoal:
    """A goal in force: its handle, the future its ``execute`` awaits, when its trajectory ends (planner's clock, s),
    its tolerances, and whether the reference is stopping for its end (``ending``: canceled or aborted)."""

    handle: ServerGoalHandle
    done: Future
    origin_s: float  #: when the goal was taken (its trajectory's time 0)
    end_s: float
    tolerances: Tolerances
    ending: tuple[str, int, str] | None = None  #: (canceled|aborted, error code, reason) once the stop is under way


def _point(positions, velocities=(), time_s: float = 0.0) -> JointTrajectoryPoint:
    point = JointTrajectoryPoint(positions=[float(x) for x in positions], velocities=[float(x) for x in velocities])
    point.time_from_start.sec, point.time_from_start.nanosec = divmod(max(0, round(time_s * 1e9)), 1_000_000_000)
    return point


class FollowJointTrajectoryServer:
    """The action server, part of the planner (``planner.action``)."""

    def __init__(self, planner: StackNode) -> None:
        """``planner``: the trajectory planner (its take_trajectory, install, stop and reference_at)."""
        self.planner = planner
        self.action = _action_type()
        self.joint_names = list(planner.limits.joint_names)
        self.name = f"/{planner.params['controller_name']}/follow_joint_trajectory"
        self.active: ActiveGoal | None = None
        self.estimate: tuple[float, np.ndarray, np.ndarray, str] | None = None  #: (tick s, reference, estimate, status)
        self.measured: tuple[np.ndarray, np.ndarray] | None = None  #: /joint_states (positions, velocities)
        self.estop = False
        self.server = ActionServer(
            planner,
            self.action,
            self.name,
            execute_callback=self.execute,
            goal_callback=lambda _request: GoalResponse.ACCEPT,
            cancel_callback=lambda _handle: CancelResponse.ACCEPT,
        )
        self.listening: list = []  #: the arm's subscriptions, while a goal is in force (``listen``)
        planner.create_subscription(Bool, "/estop", self.estop_callback, ESTOP_QOS)

    def listen(self, on: bool) -> None:
        """Hear the arm (its readings, the controller's estimate) only while a goal is in force. Two 100 Hz
        subscriptions cost the planner's executor (rclpy's single-threaded one, which rebuilds its wait set at every
        wake-up) a third of a CPU, taken from the loop on a busy host. Off, what was heard is forgotten: a next
        goal is never judged on an earlier one's estimate."""
        planner = self.planner
        if on and not self.listening:
            self.listening = [
                planner.create_subscription(JointState, "/joint_states", self.joint_states, LATEST_QOS),
                planner.create_subscription(Float64MultiArray, "/controller/state", self.controller_state, LATEST_QOS),
            ]
        elif not on and self.listening:
            for subscription in self.listening:
                planner.destroy_subscription(subscription)
            self.listening, self.estimate, self.measured = [], None, None

    # What the arm does.
    def joint_states(self, msg: JointState) -> None:
        names = list(msg.name)
        if len(msg.position) != len(names) or any(name not in names for name in self.joint_names):
            return
        order = [names.index(name) for name in self.joint_names]
        velocity = np.asarray(msg.velocity, dtype=float)[order] if len(msg.velocity) == len(names) else None
        position = np.asarray(msg.position, dtype=float)[order]
        self.measured = (position, velocity if velocity is not None else np.zeros_like(position))

    def controller_state(self, msg: Float64MultiArray) -> None:
        n = len(self.joint_names)
        if not state_layout.fits(len(msg.data), n):
            return
        state = state_layout.decode(np.asarray(msg.data, dtype=float), n)
        status = _STATUS_NAMES.get(int(state["status"]), "ok")
        self.estimate = (float(state["time_s"]), state["reference"], state["measured"], status)

    def estop_callback(self, msg: Bool) -> None:
        self.estop = bool(msg.data)

    # Goals.
    async def execute(self, handle: ServerGoalHandle):
        planner = self.planner
        now_s = planner.now_s()
        goal = handle.request
        taken = planner.take_trajectory(goal.trajectory, now_s, f"goal {_goal_id(handle)}")
        if isinstance(taken, tuple):
            code, reason = taken
            handle.abort()
            return self.action.Result(error_code=code, error_string=reason)
        tolerances = goal_tolerances(
            self.joint_names,
            [(t.name, t.position, t.velocity) for t in goal.path_tolerance],
            [(t.name, t.position, t.velocity) for t in goal.goal_tolerance],
            goal.goal_time_tolerance.sec + goal.goal_time_tolerance.nanosec * 1e-9,
            default_path_rad=planner.params["path_tolerance"],
            default_goal_rad=planner.params["goal_tolerance"],
            default_goal_time_s=planner.params["goal_time_tolerance_s"],
        )
        if isinstance(tolerances, str):
            handle.abort()
            return self.action.Result(error_code=INVALID_GOAL, error_string=tolerances)
        self.end_active("aborted", INVALID_GOAL, "preempted by a new goal", next_goal=True)
        planner.install(taken, now_s)
        self.listen(True)
        done = Future()
        self.active = ActiveGoal(handle, done, now_s, now_s + taken.trajectory.duration_s, tolerances)
        return await done

    def end_active(self, how: str, code: int, reason: str, next_goal: bool = False) -> None:
        """End the goal in force (if any) now: ``succeeded``, ``aborted`` or ``canceled``, with its result
        (``next_goal``: one that preempts it follows, and hears the arm as it did)."""
        active, self.active = self.active, None
        if not next_goal:
            self.listen(False)
        if active is None or active.done.done():
            return
        if how == "canceled" and active.handle.is_cancel_requested:
            active.handle.canceled()
        elif how == "succeeded":
            active.handle.succeed()
        else:
            active.handle.abort()
        self.planner.get_logger().info(f"goal {_goal_id(active.handle)} {how}: {reason}")
        active.done.set_result(self.action.Result(error_code=code, error_string=reason))

    def stop_and_end(self, now_s: float, how: str, code: int, reason: str) -> None:
        """Bring the reference to rest and hold it; the goal ends once it is at rest."""
        active = self.active
        if active is None or active.ending is not None:
            return
        active.ending = (how, code, reason)
        active.end_s = now_s + self.planner.stop(now_s)

    def replaced(self, by: str) -> None:
        """The motion in force was replaced by something other than a goal (the topic, the parameters)."""
        self.end_active("aborted", INVALID_GOAL, f"preempted by {by}")

    def monitor(self, now_s: float) -> None:
        """Each tick: the goal's feedback, tolerances, cancel, faults and end."""
        active = self.active
        if active is None:
            return
        if active.ending is not None:
            if now_s >= active.end_s:
                self.end_active(*active.ending)
            return
        if active.handle.is_cancel_requested:
            self.stop_and_end(now_s, "canceled", SUCCESSFUL, "the arm stopped and holds where it came to rest")
            return
        fault = self.fault()
        if fault is not None:
            self.stop_and_end(now_s, "aborted", PATH_TOLERANCE_VIOLATED, fault)
            return
        errors = self.feedback(now_s)
        if errors is None:
            return
        error, velocity_error = errors
        tolerances = active.tolerances
        if now_s < active.end_s:
            violation = tolerances.path_violation(self.joint_names, error, velocity_error)
            if violation is not None:
                self.stop_and_end(now_s, "aborted", PATH_TOLERANCE_VIOLATED, violation)
            return
        miss = tolerances.goal_miss(self.joint_names, error, velocity_error)
        late_s = now_s - active.end_s
        if miss is None:
            self.end_active("succeeded", SUCCESSFUL, f"reached within its goal tolerance {late_s:.2f} s after its end")
        elif tolerances.goal_time_s > 0.0 and late_s > tolerances.goal_time_s:
            reason = f"{miss} {tolerances.goal_time_s:g} s after the trajectory's end (goal_time_tolerance)"
            self.end_active("aborted", GOAL_TOLERANCE_VIOLATED, reason)

    def fault(self) -> str | None:
        if self.estop:
            return "e-stop: the arm is braked"
        if self.estimate is not None and self.estimate[3] in FAULT_STATES:
            return f"the controller reports {self.estimate[3]}: the loop stops"
        return None

    def feedback(self, now_s: float) -> tuple[np.ndarray, np.ndarray] | None:
        """Publish desired, actual and error; the position and velocity errors (None before the arm is heard)."""
        if self.estimate is not None:
            at_s, reference, actual, _ = self.estimate
            desired = self.planner.reference_at(at_s)
            desired = (reference, desired[1], desired[2])
        elif self.measured is not None:
            at_s, desired, actual = now_s, self.planner.reference_at(now_s), self.measured[0]
        else:
            return None
        velocity = self.measured[1] if self.measured is not None else np.zeros_like(actual)
        error, velocity_error = desired[0] - actual, desired[1] - velocity
        active = self.active
        assert active is not None
        since_s = at_s - active.origin_s
        msg = self.action.Feedback(joint_names=self.joint_names)
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(max(0, round(at_s * 1e9)), 1_000_000_000)
        msg.desired = _point(desired[0], desired[1], since_s)
        msg.desired.accelerations = [float(x) for x in desired[2]]
        msg.actual = _point(actual, velocity, since_s)
        msg.error = _point(error, velocity_error, since_s)
        active.handle.publish_feedback(msg)
        return error, velocity_error

    def shutdown(self) -> None:
        self.end_active("aborted", INVALID_GOAL, "the planner is shutting down")


def _goal_id(handle: ServerGoalHandle) -> str:
    return bytes(handle.goal_id.uuid).hex()[:8]
