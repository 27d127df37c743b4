"""The planner (the graph's ``trajectory_planner``): the reference ``[positions…, velocities…, accelerations…,
sample_time_s]``, the motion in force sampled at each step (``sample_time_s``: the step's time, so the controller
evaluates it at its own tick). Its time 0 is its first step.

Every trajectory is checked against the joints' ranges, the arm model and ``torque_max`` less ``feasibility_margin``
(``feasibility``: scale, refuse or ignore), at start and on every live change, which is blended in from the reference
in force. A joint trajectory (ports ``waypoints`` and ``controller_waypoints``, or a FollowJointTrajectory goal through
:meth:`Planner.take`) is checked against the URDF's limits too, joined onto the reference in force (first stopping
within ``stop_deceleration`` if joining directly would swing past its first point), timed from its stamp if set and
not past, and held at its last point until the next one or a change of the shape, which brings the parameters' motion
back. What the arm does goes to its ``arm`` watch (``blocks.arm_watch``), which judges a goal in force."""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.blocks.arm_watch import ArmWatch
from robot_controller.blocks.block import Log
from robot_controller.blocks.values import Array, WaypointRequest
from robot_controller.core.errors import ConfigError
from robot_controller.core.metrics import EFFORT_UNITS, in_units
from robot_controller.core.model import joint_limits
from robot_controller.core.model.velocity_envelope import ENVELOPES, position_range
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
from robot_controller.parameters.builders import TRAJECTORY_SHAPE_KEYS, arm_model, given, model_overridden
from robot_controller.parameters.torque_limits import torque_limit

#: A controller name as a ROS name segment.
_CONTROLLER_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
#: A change of these brings the parameters' motion back in place of a joint trajectory.
#: s a robot is held where it stands before the blend begins: its drive takes the planner's samples from its first
#: tick, which comes up to a few hundred ms after the planner's (a blend already under way then had to be caught up
#: with, and the catching up took the elbow past the speed its envelope allows)
START_HOLD_S = 1.0
#: of the speed a trajectory may reach, what the blend from where a robot stands may: a gentle start (at the full
#: speed the blend took 60 N·m on the Panda's base, a push the torque's rate limit cannot take back in time)
START_SPEED_SHARE = 0.3
SHAPE_KEYS = frozenset(("mode", *TRAJECTORY_SHAPE_KEYS))
#: The ports a joint trajectory comes on.
WAYPOINT_PORTS = ("waypoints", "controller_waypoints")
#: Refused: JTC's error code and the reason.
Refusal = tuple[int, str]


class Planner:
    inputs = (*WAYPOINT_PORTS, "reading", "state", "brakes", "estop")
    outputs = ("reference",)

    def __init__(self, params: Mapping[str, Any], log: Log, *, world_waits: bool = False) -> None:
        """:param world_waits: the world's brakes hold from its start until the first effort (its arm watch does
        not count them)"""
        self.log = log
        self.dynamics = arm_model(params)
        if len(self.dynamics.joint_names) != params["joint_count"]:
            raise ConfigError(
                f"joint_count {params['joint_count']} but the URDF has {len(self.dynamics.joint_names)} joint(s)"
            )
        if model_overridden(params):
            log.info(f"trajectory checked against {self.dynamics.describe()}")
        if not _CONTROLLER_NAME.fullmatch(params["controller_name"]):
            raise ConfigError(
                f"controller_name {params['controller_name']!r}: a letter, then letters, digits or '_' (a ROS name)"
            )
        self.limits = joint_limits(resources.resolve_urdf(params["urdf_path"]))
        self.params = dict(params)
        self._plan_key: tuple | None = None
        self._plan: Plan | None = None
        self._warned: str | None = None
        self.trajectory = self._planned(params).trajectory  #: the parameters' motion (its warning: at start)
        self.start_s: float | None = None  #: its first step: the parameters' motion's time 0
        self.last_step_s = 0.0
        self.waypoints: Trajectory | None = None  #: a joint trajectory (or a goal's stop) in force, if any
        self.origin_s = 0.0  #: when the motion in force has its time 0 (the start, or a joint trajectory's receipt)
        self.crossfade: Crossfade | None = None  #: a live change being blended in
        #: told (with what replaced it) when the motion in force gives way to another (the action server ends its goal)
        self.replaced: list[Callable[[str], None]] = []
        self.arm = ArmWatch(self.limits.joint_names, 1.0 / params["publish_rate_hz"], world_waits=world_waits)

    def start(self) -> dict[str, Any]:
        """Say the plan's warning (slowed, or run as it is), once the host is ready to speak."""
        self.trajectory = self._make(self.params)
        return {}

    def wake_period_s(self) -> float | None:
        return 1.0 / self.params["publish_rate_hz"]

    def step(self, t_s: float, inputs: Mapping[str, Any]) -> dict[str, Any]:
        """Take the joint trajectories and what the arm does that arrived at ``t_s``; stepped with none, sample the
        reference at ``t_s``."""
        for name, value in inputs.items():
            if name in WAYPOINT_PORTS:
                self.take_waypoints(value, t_s)
            else:
                self.arm.take(name, value, t_s)
        if inputs:
            return {}
        if self.start_s is None:
            self.start_s = self.origin_s = t_s
            if given(self.params["start_position"]):  # a robot, left where it was jogged
                self.start_from(np.asarray(self.params["start_position"], float), t_s + START_HOLD_S)
        self.last_step_s = t_s
        position, velocity, acceleration = self.reference_at(t_s)
        # Written into one new array (the port's value, kept by its readers): cheaper than concatenating four.
        n = position.size
        reference = np.empty(3 * n + 1)
        reference[:n] = position
        reference[n : 2 * n] = velocity
        reference[2 * n : 3 * n] = acceleration
        reference[3 * n] = t_s
        return {"reference": Array(reference)}

    def check_params(self, params: Mapping[str, Any]) -> None:
        self._planned(params)

    def set_params(self, params: Mapping[str, Any], changed: set[str], now_s: float | None = None) -> None:
        """Take new values at ``now_s`` (the host's clock; None: the last step's time): a new motion is blended in
        from the reference in force, and a shape change ends a joint trajectory in force."""
        now_s = self.last_step_s if now_s is None else now_s
        self.params = dict(params)
        self.arm.own_period_s = 1.0 / params["publish_rate_hz"]
        before, previous = self.motion_in_force(), repr(self.trajectory)  # (the dataclass's values)
        self.trajectory = self._make(params)
        moved = repr(self.trajectory) != previous
        if self.waypoints is not None and changed & SHAPE_KEYS:
            self._tell_replaced("a change of the parameters' motion")
            self.waypoints, moved = None, True
            self.origin_s = self.start_s or 0.0
            self.log.info(f"joint trajectory left for the parameters' {params['mode']}")
        if self.start_s is not None and self.waypoints is None and moved:
            self.blend_from(before, now_s)

    def summary(self, clock: str = "") -> str:
        """What it publishes, in one line (``clock``: what its host says of its clock)."""
        p = self.params
        return (
            f"trajectory: {p['mode']}, amplitude {in_units(p['amplitude'], self.dynamics.joint_units)}, "
            f"{p['frequency_hz']:g} Hz, published at {p['publish_rate_hz']:g} Hz" + clock + self._slowed()
        )

    def _planned(self, params: Mapping[str, Any]) -> Plan:
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
                velocity_limit=params["velocity_share"] * self.limits.velocity,
                position_range=position_range(self.limits, params),
                envelope=ENVELOPES.get(params["velocity_envelope"]),
            )
            self._plan_key = key
        assert self._plan is not None
        return self._plan

    def _make(self, params: Mapping[str, Any]) -> Trajectory:
        plan = self._planned(params)
        if plan.warning is not None and plan.warning != self._warned:
            self.log.warn(plan.warning, plan.warning)
        self._warned = plan.warning
        return plan.trajectory

    def _slowed(self) -> str:
        plan = self._plan
        if plan is None or self.params["feasibility"] != "scale" or not 1.0 < plan.result.scale < float("inf"):
            return ""
        return f", slowed in time ×{plan.result.scale:.2f} to fit the torque limit"

    def blend_from(self, before: Motion, now_s: float, speed_share: float = 1.0) -> None:
        """A live change starts from the reference in force, blended into the new motion (no jump), within
        ``speed_share`` of the speed the trajectory may reach."""
        params = self.params
        usable = torque_limit(params, len(self.limits.joint_names)) * (1.0 - params["feasibility_margin"])
        self.crossfade = None  # (a blend under way is ``before``)
        shared = params["velocity_share"] * self.limits.velocity
        speeds = speed_share * shared
        envelope = ENVELOPES.get(params["velocity_envelope"])
        speed_at = None
        if envelope is not None:  # the trajectory's share of the robot's envelope, wherever the blend goes

            def speed_at(position: np.ndarray, velocity: np.ndarray) -> np.ndarray:
                return shared / envelope.max_rad_s * envelope.limit(position, velocity)

        self.crossfade = crossfade(before, self.motion_in_force(), now_s, self.dynamics, usable, speeds, speed_at)
        gap = np.abs(before(now_s)[0] - self.crossfade.new(now_s)[0])
        j = int(np.argmax(gap))
        self.log.info(
            f"new {params['mode']} blended in over {self.crossfade.duration_s:.2f} s "
            f"({gap[j]:.3g} {self.dynamics.joint_units[j]} away)"
        )

    def start_from(self, position: np.ndarray, t_s: float) -> None:
        """The arm starts where it stands (a real one, left wherever it was jogged): the motion's time 0 is ``t_s``,
        blended in from ``position`` held, within the torque and speed limits (no jump)."""
        self.start_s = self.origin_s = self.last_step_s = t_s
        held = np.array(position, float)
        still = np.zeros_like(held)
        self.blend_from(lambda _time_s: (held, still, still), t_s, START_SPEED_SHARE)

    def motion_in_force(self) -> Motion:
        """The reference as a function of the planner's time (s): the blend under way, a joint trajectory's, else
        the parameters' motion."""
        if self.crossfade is not None:
            return self.crossfade.at
        motion, origin_s = (self.waypoints if self.waypoints is not None else self.trajectory), self.origin_s
        return lambda time_s: motion.sample(time_s - origin_s)

    def reference_at(self, now_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The motion in force (:meth:`motion_in_force`) at ``now_s``, sampled without making it a function (each
        step's)."""
        if self.crossfade is not None:
            if not self.crossfade.done(now_s):
                return self.crossfade.at(now_s)
            self.crossfade = None
        motion = self.waypoints if self.waypoints is not None else self.trajectory
        return motion.sample(now_s - self.origin_s)

    def _tell_replaced(self, by: str) -> None:
        for listener in self.replaced:
            listener(by)

    def take_waypoints(self, request: WaypointRequest, now_s: float) -> None:
        """A joint trajectory from the topic: in force from ``now_s`` if it can be taken, else said (at most once
        per 2 s: the topic has no answer) and the motion goes on."""
        taken = self.take(request, now_s)
        if not isinstance(taken, Accepted):
            self.log.warn("joint_trajectory", f"joint trajectory refused: {taken[1]}; the motion goes on as it was")
            return
        self._tell_replaced("a trajectory on the topic")
        self.install(taken, now_s)

    def take(self, request: WaypointRequest, now_s: float) -> Accepted | Refusal:
        """``request`` checked and joined onto the reference in force at ``now_s`` (not yet in force:
        :meth:`install`); or, refused, JTC's error code and the reason."""
        prepared = self._points(request, now_s)
        if isinstance(prepared[0], int):
            return prepared
        *points, delay = prepared
        accepted = accept_joint_trajectory(
            *points,
            start=self.reference_at(now_s),
            limits=dataclasses.replace(self.limits, velocity=self.params["velocity_share"] * self.limits.velocity),
            dynamics=self.dynamics,
            torque_limit_nm=torque_limit(self.params, len(self.limits.joint_names)),
            margin=self.params["feasibility_margin"],
            start_delay_s=delay,
            torque_policy="warn" if self.params["feasibility"] == "ignore" else "refuse",
            stop_deceleration=self.params["stop_deceleration"],
        )
        return (INVALID_GOAL, accepted) if isinstance(accepted, str) else accepted

    def install(self, taken: Accepted, now_s: float) -> None:
        """Put a taken trajectory in force from ``now_s`` (it starts from the reference in force) and say so."""
        trajectory = taken.trajectory
        self.waypoints, self.origin_s, self.crossfade = trajectory, now_s, None  # it starts from the blend
        points = len(trajectory.waypoints.times_s)
        units, delayed = self.dynamics.joint_units, trajectory.start_delay_s
        target = in_units(np.round(trajectory.final_position, 4), units)
        j = int(np.argmax(taken.peak_torque_nm))
        effort = "torque" if units[j] == "rad" else "force"
        self.log.info(
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
            line = f"{taken.warning}; running it as it is (feasibility: ignore)"
            self.log.warn(line, line)

    def stop(self, now_s: float) -> float:
        """Bring the reference to rest within ``stop_deceleration`` from ``now_s`` (sooner if it would rest beyond a
        joint's range), then hold; the stop's length, s."""
        limits = self.limits
        path = stop_path(self.reference_at(now_s), self.params["stop_deceleration"], (limits.lower, limits.upper))
        self.waypoints, self.origin_s, self.crossfade = path, now_s, None
        return path.duration_s

    def check_goal(self, request: WaypointRequest, now_s: float) -> Refusal | None:
        """Why ``request`` cannot be taken, as JTC's goal callback says it (its error code and the reason), or None;
        its join onto the reference in force (the path between the points, the torque) is checked when it is taken."""
        prepared = self._points(request, now_s)
        return prepared if isinstance(prepared[0], int) else None

    def _points(self, request: WaypointRequest, now_s: float) -> tuple:
        """``(names, times, positions, velocities, accelerations, start delay)`` in the arm's terms, every joint
        given, checked (``check_waypoints``); or JTC's error code and the reason."""
        if self.start_s is None:
            return INVALID_GOAL, "the planner is not publishing yet (its consumers are not matched)"
        arm = list(self.limits.joint_names)
        names = list(request.joint_names)
        reason = joint_names_problem(names, arm, self.params["allow_partial_joints_goal"])
        if reason is not None:
            return INVALID_JOINTS, reason
        times = list(request.times_s)
        stamp_s = request.stamp_s
        if stamp_s != 0.0 and times and stamp_s + max(times) < now_s:
            return OLD_HEADER_TIMESTAMP, (
                f"header.stamp {stamp_s:.3f} s plus its last point's {max(times):g} s is before the planner's clock "
                f"({now_s:.3f} s): the trajectory is over before it arrives"
            )
        delay = start_delay(stamp_s, now_s)
        if isinstance(delay, str):
            return INVALID_GOAL, delay
        positions = [list(row) for row in request.positions]
        velocities = [list(row) for row in request.velocities] or [[] for _ in times]
        accelerations = [list(row) for row in request.accelerations] or [[] for _ in times]
        if len(names) < len(arm):
            names, positions, velocities, accelerations = complete_joints(
                names, arm, self.reference_at(now_s)[0], positions, velocities, accelerations
            )
        checked = check_waypoints(names, times, positions, velocities, accelerations, self.limits)
        if isinstance(checked, str):
            return INVALID_GOAL, checked
        return names, times, positions, velocities, accelerations, delay
