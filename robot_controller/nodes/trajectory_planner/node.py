"""The planner node: the reference (port ``reference``), ``[positions…, velocities…, accelerations…,
time_s]`` (``time_s``: when the sample was taken, so the controller evaluates it at its own tick).
Time starts when the first consumer is matched. Lockstep: each grid point's sample goes one tick early.

Every trajectory is checked against the joints' ranges, the arm model and ``torque_max`` less
``feasibility_margin`` (``core.reference``; ``feasibility``: scale, refuse or ignore), at start and on
every live change, which is blended in from the reference in force (``core.reference.crossfade``). A
``JointTrajectory`` on JointTrajectoryController's topic for ``controller_name`` (port ``controller_waypoints``, as
ros2_controllers' controller takes it; port ``waypoints`` too) or in a FollowJointTrajectory goal
(``follow_joint_trajectory``) is checked against the URDF's limits too, joined onto the reference in force (first
stopping within ``stop_deceleration`` if joining directly would swing past its first point), timed from
``header.stamp`` if set and not past, and held at its last point until the next one or a change of the shape.
"""

from __future__ import annotations

import re
from typing import Any

import numpy as np
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg
from std_msgs.msg import Float64MultiArray, MultiArrayDimension
from trajectory_msgs.msg import JointTrajectory as JointTrajectoryMsg

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.blocks import spec
from robot_controller.core.errors import ConfigError
from robot_controller.core.metrics import EFFORT_UNITS, in_units
from robot_controller.core.model import joint_limits, urdf_velocity_limits
from robot_controller.core.reference import (
    Accepted,
    Crossfade,
    Plan,
    Trajectory,
    accept_joint_trajectory,
    crossfade,
    make_trajectory,
    plan_trajectory,
    start_delay,
)
from robot_controller.core.reference.crossfade import Motion
from robot_controller.core.reference.joint_trajectory import check_waypoints, complete_joints, joint_names_problem
from robot_controller.core.reference.stop import stop_path
from robot_controller.core.reference.tolerances import INVALID_GOAL, INVALID_JOINTS, OLD_HEADER_TIMESTAMP
from robot_controller.nodes.trajectory_planner.follow_joint_trajectory import FollowJointTrajectoryServer
from robot_controller.parameters.builders import TRAJECTORY_SHAPE_KEYS, arm_model, model_overridden
from robot_controller.parameters.torque_limits import torque_limit
from robot_controller.ros.messages import clock_s, stamp_to_s
from robot_controller.ros.process import run
from robot_controller.ros.qos import CONTROL_QOS, LATEST_QOS
from robot_controller.ros.stack_node import StackNode

_GRID_EPS_S = 1e-6
#: A controller name as a ROS name segment.
_CONTROLLER_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
# A change of these brings the parameters' motion back in place of a joint trajectory.
SHAPE_KEYS = frozenset(("mode", *TRAJECTORY_SHAPE_KEYS))


class TrajectoryPlanner(StackNode):
    serves_actions = True  #: spun by an executor that serves action servers (ros.process.make_executor)

    def __init__(self) -> None:
        self._plan_key: tuple | None = None
        self._plan: Plan | None = None
        self._warned: str | None = None
        super().__init__("trajectory_planner")
        p = self.params
        self.trajectory = self._make(p)
        self.pub = self.gated_publisher(Float64MultiArray, spec.REFERENCE.topic)
        self.start_s: float | None = None
        self.next_sample_s = 0.0
        self.waypoints: Trajectory | None = None  # a joint trajectory (or a goal's stop) in force, if any
        self.origin_s = 0.0  # when the motion in force has its time 0 (the start, or a joint trajectory's receipt)
        self.crossfade: Crossfade | None = None  # a live change being blended in
        self.clock_s = 0.0  # lockstep: the sim's latest clock (time is 0 until the first)
        self.msg = Float64MultiArray()
        n = p["joint_count"]
        self.msg.layout.dim = [
            MultiArrayDimension(label=name, size=n, stride=n) for name in ("position", "velocity", "acceleration")
        ]
        self.msg.layout.dim.append(MultiArrayDimension(label="time_s", size=1, stride=1))
        self.timer = None
        if p["lockstep"]:
            self.create_subscription(ClockMsg, spec.CLOCK.topic, self.clock_callback, CONTROL_QOS)
            # Before the sim's first clock the time is 0: poll (on the wall clock) for the controller.
            self.start_poll = self.create_timer(
                0.05, lambda: self.sample_at(self.clock_s), clock=Clock(clock_type=ClockType.STEADY_TIME)
            )
        else:
            self.timer = self.create_timer(1.0 / p["publish_rate_hz"], self.wall_tick)
        for topic in (spec.WAYPOINTS.topic, spec.CONTROLLER_WAYPOINTS.topic_for(p["controller_name"])):
            self.create_subscription(JointTrajectoryMsg, topic, self.joint_trajectory_callback, LATEST_QOS)
        self.action = FollowJointTrajectoryServer(self)
        self.get_logger().info(
            f"trajectory: {p['mode']}, amplitude {in_units(p['amplitude'], self.dynamics.joint_units)}, "
            f"{p['frequency_hz']:g} Hz, published at {p['publish_rate_hz']:g} Hz"
            + (", lockstep" if p["lockstep"] else "")
            + self._slowed()
        )

    def setup(self, params: dict[str, Any]) -> None:
        # The arm model: the URDF's, or the model_* values over it (read-only: fixed at start).
        self.dynamics = arm_model(params)
        if len(self.dynamics.joint_names) != params["joint_count"]:
            raise ConfigError(
                f"joint_count {params['joint_count']} but the URDF has {len(self.dynamics.joint_names)} joint(s)"
            )
        if model_overridden(params):
            self.get_logger().info(f"trajectory checked against {self.dynamics.describe()}")
        if not _CONTROLLER_NAME.fullmatch(params["controller_name"]):
            raise ConfigError(
                f"controller_name {params['controller_name']!r}: a letter, then letters, digits or '_' (a ROS name)"
            )
        # Position and velocity limits (read-only URDF: fixed at start).
        self.limits = joint_limits(resources.resolve_urdf(params["urdf_path"]))

    def _planned(self, params: dict[str, Any]) -> Plan:
        """The trajectory the values describe, slowed if it must be (``ConfigError`` if it is refused)."""
        key = tuple(sorted((name, repr(value)) for name, value in params.items()))  # checked once per change
        if key != self._plan_key:
            trajectory = make_trajectory(params["mode"], **cfg.trajectory_kwargs(params))
            self._plan = plan_trajectory(
                trajectory,
                self.dynamics,
                torque_limit(params, len(self.dynamics.joint_names)),
                margin=params["feasibility_margin"],
                policy=params["feasibility"],
                what=params["mode"],
                joint_names=self.dynamics.joint_names,
                velocity_limit=urdf_velocity_limits(
                    resources.resolve_urdf(params["urdf_path"]), self.dynamics.joint_names
                ),
                position_range=(self.limits.lower, self.limits.upper),
            )
            self._plan_key = key
        assert self._plan is not None
        return self._plan

    def _make(self, params: dict[str, Any]) -> Trajectory:
        plan = self._planned(params)
        if plan.warning is not None and plan.warning != self._warned:
            self.get_logger().warning(plan.warning)
        self._warned = plan.warning
        return plan.trajectory

    def _slowed(self) -> str:
        plan = self._plan
        if plan is None or self.params["feasibility"] != "scale" or not 1.0 < plan.result.scale < float("inf"):
            return ""
        return f", slowed in time ×{plan.result.scale:.2f} to fit the torque limit"

    def check_params(self, params: dict[str, Any]) -> None:
        self._planned(params)

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        before, previous = self.motion_in_force(), repr(self.trajectory)  # (the dataclass's values)
        self.trajectory = self._make(params)
        moved = repr(self.trajectory) != previous
        if self.waypoints is not None and changed & SHAPE_KEYS:
            self.action.replaced("a change of the parameters' motion")
            self.waypoints, moved = None, True
            self.origin_s = self.start_s or 0.0
            self.get_logger().info(f"joint trajectory left for the parameters' {params['mode']}")
        if self.start_s is not None and self.waypoints is None and moved:
            self.blend_from(before, params)
        if "publish_rate_hz" in changed and self.timer is not None:
            self.destroy_timer(self.timer)
            self.timer = self.create_timer(1.0 / params["publish_rate_hz"], self.wall_tick)

    def now_s(self) -> float:
        """The planner's time: the sim's latest clock in lockstep, else the node's clock, s."""
        return self.clock_s if self.params["lockstep"] else clock_s(self)

    def wall_tick(self) -> None:
        now_s = clock_s(self)
        self.sample_at(now_s)
        if self.start_s is not None:
            self.action.monitor(now_s)

    def clock_callback(self, msg: ClockMsg) -> None:
        previous_s, self.clock_s = self.clock_s, stamp_to_s(msg.clock)
        if self.start_s is None:
            return
        self.sample_at(self.clock_s)
        # The sample due at the next tick goes out now, a tick early: the controller holds it
        # until its time, and its tick never waits for this process (the sim's step is the tick).
        step_s = self.clock_s - previous_s
        if step_s > 0:
            self.sample_at(self.clock_s + step_s)
        self.action.monitor(self.clock_s)

    def sample_at(self, now_s: float) -> None:
        if self.start_s is None:
            if not self.pub.open:
                return  # t = 0 is when the controller (and the recorder) can hear it
            self.start_s = now_s
            self.next_sample_s = now_s
            self.origin_s = now_s
            if self.params["lockstep"]:
                self.destroy_timer(self.start_poll)
        if self.params["lockstep"]:
            if now_s < self.next_sample_s - _GRID_EPS_S:
                return
            period = 1.0 / self.params["publish_rate_hz"]
            self.next_sample_s = self.start_s + (np.floor((now_s - self.start_s + _GRID_EPS_S) / period) + 1) * period
        position, velocity, acceleration = self.reference_at(now_s)
        self.msg.data = np.concatenate((position, velocity, acceleration, [now_s])).tolist()
        self.pub.publish(self.msg)

    def blend_from(self, before: Motion, params: dict[str, Any]) -> None:
        """A live change starts from the reference in force, blended into the new motion (no jump)."""
        now_s = self.now_s()
        usable = torque_limit(params, len(self.limits.joint_names)) * (1.0 - params["feasibility_margin"])
        self.crossfade = None  # (a blend under way is ``before``)
        self.crossfade = crossfade(before, self.motion_in_force(), now_s, self.dynamics, usable, self.limits.velocity)
        gap = np.abs(before(now_s)[0] - self.crossfade.new(now_s)[0])
        j = int(np.argmax(gap))
        self.get_logger().info(
            f"new {params['mode']} blended in over {self.crossfade.duration_s:.2f} s "
            f"({gap[j]:.3g} {self.dynamics.joint_units[j]} away)"
        )

    def motion_in_force(self) -> Motion:
        """The reference as a function of the planner's time (s): the blend under way, a joint
        trajectory's, else the parameters' motion."""
        if self.crossfade is not None:
            return self.crossfade.at
        motion, origin_s = (self.waypoints if self.waypoints is not None else self.trajectory), self.origin_s
        return lambda time_s: motion.sample(time_s - origin_s)

    def reference_at(self, now_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The reference in force at ``now_s``."""
        if self.crossfade is not None and self.crossfade.done(now_s):
            self.crossfade = None
        return self.motion_in_force()(now_s)

    def joint_trajectory_callback(self, msg: JointTrajectoryMsg) -> None:
        now_s = self.now_s()
        taken = self.take_trajectory(msg, now_s, "joint trajectory")
        if isinstance(taken, tuple):
            return
        self.action.replaced("a trajectory on the topic")
        self.install(taken, now_s)

    def take_trajectory(self, msg: JointTrajectoryMsg, now_s: float, what: str) -> Accepted | tuple[int, str]:
        """``msg`` checked and joined onto the reference in force at ``now_s``; or, refused, JTC's error code and
        the reason (said in the log, at most once per 2 s for the topic: a goal's client has its result)."""
        taken = self._joint_trajectory(msg, now_s)
        if isinstance(taken, Accepted):
            return taken
        code, reason = taken
        line = f"{what} refused: {reason}; the motion goes on as it was"
        if what == "joint trajectory":
            self.warn_throttled("joint_trajectory", line)
        else:
            self.get_logger().warning(line)
        return code, reason

    def install(self, taken: Accepted, now_s: float) -> None:
        """Put a taken trajectory in force from ``now_s`` (it starts from the reference in force) and say so."""
        trajectory = taken.trajectory
        self.waypoints, self.origin_s, self.crossfade = trajectory, now_s, None  # it starts from the blend
        points = len(trajectory.waypoints.times_s)
        units, delayed = self.dynamics.joint_units, trajectory.start_delay_s
        target = in_units(np.round(trajectory.final_position, 4), units)
        j = int(np.argmax(taken.peak_torque_nm))
        effort = "torque" if units[j] == "rad" else "force"
        self.get_logger().info(
            f"joint trajectory taken: {points} point(s), reaching {target} {trajectory.duration_s:.3g} s from now"
            + (f" (its time 0 at its stamp, {delayed:.3g} s from now)" if delayed else "")
            + (
                f" (after a stop of {trajectory.stop_first_s:.2f} s: joining it directly swung past its first point)"
                if trajectory.stop_first_s
                else ""
            )
            + f"; peak {effort} {taken.peak_torque_nm[j]:.2f} {EFFORT_UNITS[units[j]]} on {self.limits.joint_names[j]}"
        )
        if taken.warning is not None:
            self.get_logger().warning(f"{taken.warning}; running it as it is (feasibility: ignore)")

    def stop(self, now_s: float) -> float:
        """Bring the reference to rest within ``stop_deceleration`` from ``now_s`` (sooner if it would rest beyond a
        joint's range), then hold; the stop's length, s."""
        limits = self.limits
        path = stop_path(self.reference_at(now_s), self.params["stop_deceleration"], (limits.lower, limits.upper))
        self.waypoints, self.origin_s, self.crossfade = path, now_s, None
        return path.duration_s

    def check_goal(self, msg: JointTrajectoryMsg, now_s: float) -> tuple[int, str] | None:
        """Why ``msg`` cannot be taken, as JTC's goal callback says it (its error code and the reason), or None: its
        joints, points, times and values against the URDF's limits, and its stamp. Its join onto the reference in force
        (the path between the points, the torque) is checked when it is taken."""
        prepared = self._points(msg, now_s)
        return prepared if isinstance(prepared[0], int) else None

    def _points(self, msg: JointTrajectoryMsg, now_s: float) -> tuple:
        """``(names, times, positions, velocities, accelerations, start delay)`` in the arm's terms, every joint
        given, checked (``check_waypoints``); or JTC's error code and the reason."""
        if self.start_s is None:
            return INVALID_GOAL, "the planner is not publishing yet (its consumers are not matched)"
        arm = list(self.limits.joint_names)
        names = list(msg.joint_names)
        reason = joint_names_problem(names, arm, self.params["allow_partial_joints_goal"])
        if reason is not None:
            return INVALID_JOINTS, reason
        points = msg.points
        times = [point.time_from_start.sec + point.time_from_start.nanosec * 1e-9 for point in points]
        stamp_s = stamp_to_s(msg.header.stamp)
        if stamp_s != 0.0 and times and stamp_s + max(times) < now_s:
            return OLD_HEADER_TIMESTAMP, (
                f"header.stamp {stamp_s:.3f} s plus its last point's {max(times):g} s is before the planner's clock "
                f"({now_s:.3f} s): the trajectory is over before it arrives"
            )
        delay = start_delay(stamp_s, now_s)
        if isinstance(delay, str):
            return INVALID_GOAL, delay
        positions = [list(point.positions) for point in points]
        velocities = [list(point.velocities) for point in points]
        accelerations = [list(point.accelerations) for point in points]
        if len(names) < len(arm):
            names, positions, velocities, accelerations = complete_joints(
                names, arm, self.reference_at(now_s)[0], positions, velocities, accelerations
            )
        checked = check_waypoints(names, times, positions, velocities, accelerations, self.limits)
        if isinstance(checked, str):
            return INVALID_GOAL, checked
        return names, times, positions, velocities, accelerations, delay

    def _joint_trajectory(self, msg: JointTrajectoryMsg, now_s: float) -> Accepted | tuple[int, str]:
        prepared = self._points(msg, now_s)
        if isinstance(prepared[0], int):
            return prepared
        names, times, positions, velocities, accelerations, delay = prepared
        accepted = accept_joint_trajectory(
            names,
            times,
            positions,
            velocities,
            accelerations,
            start=self.reference_at(now_s),
            limits=self.limits,
            dynamics=self.dynamics,
            torque_limit_nm=torque_limit(self.params, len(self.limits.joint_names)),
            margin=self.params["feasibility_margin"],
            start_delay_s=delay,
            torque_policy="warn" if self.params["feasibility"] == "ignore" else "refuse",
            stop_deceleration=self.params["stop_deceleration"],
        )
        return (INVALID_GOAL, accepted) if isinstance(accepted, str) else accepted

    def finish(self) -> None:
        self.action.shutdown()
        super().finish()


def main(args: list[str] | None = None) -> int:
    return run(TrajectoryPlanner, args)


if __name__ == "__main__":
    raise SystemExit(main())
