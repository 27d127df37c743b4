"""The planner's FollowJointTrajectory action server (``blocks.spec.FOLLOW_JOINT_TRAJECTORY``), served as
ros2_controllers' JointTrajectoryController serves it, so MoveIt and any action client can drive the arm.

A goal is checked in the goal callback as JTC checks it (the planner block's ``check_goal``): one that fails is
REJECTED, the reason said in one warning line ("goal rejected: …", which ``robot-controller goto`` reads back from
the log topic: the action's answer carries no reason). An accepted goal's trajectory is joined onto the reference in
force (the block's ``take``); if the join cannot be taken the goal is aborted at once with JTC's error code and the
reason, and the motion in force goes on. A taken goal preempts the one in force. At every tick the feedback carries
desired, actual and error, and the tolerances are checked (``core.reference.tolerances``): outside a path tolerance,
or not within the goal tolerance in time, the goal aborts and the reference stops (``stop_deceleration``) and holds.
A cancel stops and holds the same way, the goal CANCELED once at rest. An e-stop, the brakes, a controller fault or
its state gone stale (``blocks.arm_watch``) abort the goal with the reason.

"Actual" is the controller's estimate on its state (port ``state``: the noisy readings would trip a tight tolerance
on noise alone); a controller that publishes none (the tutorial's) is judged on the readings. Velocities are the
readings'. The goal succeeds only on a fresh state heard after the trajectory's end with every joint within its goal
tolerance of the last point: never on an estimate from before a stall.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.action.server import ServerGoalHandle
from rclpy.node import Node
from rclpy.task import Future
from trajectory_msgs.msg import JointTrajectoryPoint

from robot_controller.blocks import spec
from robot_controller.blocks.planner import Planner
from robot_controller.core.reference.tolerances import (
    GOAL_REJECTED_LOG,
    GOAL_TOLERANCE_VIOLATED,
    INVALID_GOAL,
    PATH_TOLERANCE_VIOLATED,
    SUCCESSFUL,
    Tolerances,
    goal_tolerances,
)
from robot_controller.ros.messages import decode


def _action_type():
    from control_msgs.action import FollowJointTrajectory  # built at install (Makefile: control_msgs)

    return FollowJointTrajectory


@dataclass
class ActiveGoal:
    """A goal in force, and whether the reference is stopping for its end (``ending``: canceled or aborted)."""

    handle: ServerGoalHandle
    done: Future
    origin_s: float  #: when the goal was taken (its trajectory's time 0)
    end_s: float  #: when its trajectory ends (planner's clock, s)
    target: np.ndarray  #: the last point, the arm's order
    tolerances: Tolerances
    ending: tuple[str, int, str] | None = None  #: (canceled|aborted, error code, reason) once the stop is under way


def _point(positions, velocities=(), time_s: float = 0.0) -> JointTrajectoryPoint:
    point = JointTrajectoryPoint(positions=[float(x) for x in positions], velocities=[float(x) for x in velocities])
    point.time_from_start.sec, point.time_from_start.nanosec = divmod(max(0, round(time_s * 1e9)), 1_000_000_000)
    return point


class FollowJointTrajectoryServer:
    """The action server, beside the planner block in its node (``node.action``)."""

    def __init__(
        self, node: Node, planner: Planner, *, now_s: Callable[[], float], listen: Callable[[bool], None]
    ) -> None:
        self.node, self.now_s, self.listen = node, now_s, listen
        self.planner = planner
        self.action = _action_type()
        self.joint_names = list(planner.limits.joint_names)
        self.name = spec.FOLLOW_JOINT_TRAJECTORY.action_for(node.params["controller_name"])
        self.active: ActiveGoal | None = None
        self.watch = planner.arm
        self.server = ActionServer(
            node,
            self.action,
            self.name,
            execute_callback=self.execute,
            goal_callback=self.goal_callback,
            cancel_callback=lambda _handle: CancelResponse.ACCEPT,
        )

    def tolerances(self, goal) -> Tolerances | str:
        """The goal's tolerances in force, or why they are invalid."""
        params = self.node.params
        return goal_tolerances(
            self.joint_names,
            [(t.name, t.position, t.velocity) for t in goal.path_tolerance],
            [(t.name, t.position, t.velocity) for t in goal.goal_tolerance],
            goal.goal_time_tolerance.sec + goal.goal_time_tolerance.nanosec * 1e-9,
            default_path_rad=params["path_tolerance"],
            default_goal_rad=params["goal_tolerance"],
            default_goal_time_s=params["goal_time_tolerance_s"],
        )

    def goal_callback(self, goal) -> GoalResponse:
        """Accept a goal JTC would accept; reject any other, saying why in one warning line (the protocol's answer
        has no room for a reason)."""
        reason = self.rejection(goal)
        if reason is None:
            return GoalResponse.ACCEPT
        self.node.get_logger().warning(f"{GOAL_REJECTED_LOG}{reason}")
        return GoalResponse.REJECT

    def rejection(self, goal) -> str | None:
        if self.watch.estop:
            return "the e-stop is engaged: release it first"
        checked = self.planner.check_goal(decode(goal.trajectory), self.now_s())
        if checked is not None:
            return checked[1]
        tolerances = self.tolerances(goal)
        return tolerances if isinstance(tolerances, str) else None

    # Goals.
    async def execute(self, handle: ServerGoalHandle):
        planner = self.planner
        now_s = self.now_s()
        goal = handle.request
        taken = planner.take(decode(goal.trajectory), now_s)
        if isinstance(taken, tuple):
            code, reason = taken
            self.node.get_logger().warning(f"goal {_goal_id(handle)} refused: {reason}; the motion goes on as it was")
            handle.abort()
            return self.action.Result(error_code=code, error_string=reason)
        tolerances = self.tolerances(goal)
        if isinstance(tolerances, str):  # (checked when the goal came: the parameters changed since)
            handle.abort()
            return self.action.Result(error_code=INVALID_GOAL, error_string=tolerances)
        self.end_active("aborted", INVALID_GOAL, "preempted by a new goal", next_goal=True)
        planner.install(taken, now_s)
        self.listen(True)
        self.watch.new_goal()
        done = Future()
        end_s = now_s + taken.trajectory.duration_s
        self.active = ActiveGoal(handle, done, now_s, end_s, taken.trajectory.final_position, tolerances)
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
        line = f"goal {_goal_id(active.handle)} {how}: {reason}"
        if how == "aborted" and code != INVALID_GOAL:  # a fault or a tolerance missed, not a preemption
            self.node.get_logger().warning(line)
        else:
            self.node.get_logger().info(line)
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
        fault = self.watch.fault(now_s)
        if fault is not None:
            self.stop_and_end(now_s, "aborted", PATH_TOLERANCE_VIOLATED, fault)
            return
        judged = self.feedback(now_s)
        if judged is None:
            return
        heard_s, error, velocity_error = judged
        tolerances = active.tolerances
        if now_s < active.end_s:
            violation = tolerances.path_violation(self.joint_names, error, velocity_error)
            if violation is not None:
                self.stop_and_end(now_s, "aborted", PATH_TOLERANCE_VIOLATED, violation)
            return
        late_s = now_s - active.end_s
        if heard_s >= active.end_s and self.watch.fresh(now_s):  # what the arm did after the end, not before
            miss = tolerances.goal_miss(self.joint_names, error, velocity_error)
            if miss is None:
                reason = f"reached within its goal tolerance {late_s:.2f} s after its end"
                self.end_active("succeeded", SUCCESSFUL, reason)
                return
        else:
            miss = "the arm's state after the trajectory's end was not heard"
        if tolerances.goal_time_s > 0.0 and late_s > tolerances.goal_time_s:
            reason = f"{miss} {tolerances.goal_time_s:g} s after the trajectory's end (goal_time_tolerance)"
            self.end_active("aborted", GOAL_TOLERANCE_VIOLATED, reason)

    def feedback(self, now_s: float) -> tuple[float, np.ndarray, np.ndarray] | None:
        """Publish desired, actual and error; when what it judges was heard (the planner's clock), and the position
        and velocity errors: against the reference while the trajectory runs, against its last point from its end
        (None before the arm is heard)."""
        watch, active = self.watch, self.active
        assert active is not None
        if watch.estimate is not None:
            at_s, heard_s = watch.estimate.time_s, watch.estimate.received_s
            actual = watch.estimate.measured
            desired = self.planner.reference_at(at_s)
            desired = (watch.estimate.reference, desired[1], desired[2])
        elif watch.measured is not None:
            at_s = heard_s = watch.measured[0]
            desired, actual = self.planner.reference_at(now_s), watch.measured[1]
        else:
            return None
        velocity = watch.measured[2] if watch.measured is not None else np.zeros_like(actual)
        if heard_s >= active.end_s:
            desired = (active.target, np.zeros_like(actual), np.zeros_like(actual))
        error, velocity_error = desired[0] - actual, desired[1] - velocity
        since_s = at_s - active.origin_s
        msg = self.action.Feedback(joint_names=self.joint_names)
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(max(0, round(at_s * 1e9)), 1_000_000_000)
        msg.desired = _point(desired[0], desired[1], since_s)
        msg.desired.accelerations = [float(x) for x in desired[2]]
        msg.actual = _point(actual, velocity, since_s)
        msg.error = _point(error, velocity_error, since_s)
        active.handle.publish_feedback(msg)
        return heard_s, error, velocity_error

    def shutdown(self) -> None:
        self.end_active("aborted", INVALID_GOAL, "the planner is shutting down")


def _goal_id(handle: ServerGoalHandle) -> str:
    return bytes(handle.goal_id.uuid).hex()[:8]
