"""The world (the graph's ``simulator``, the Gazebo role): MuJoCo steps the arm from its URDF at ``physics_rate_hz`` on
the effort in force (clamped to the URDF's limits, ignored while the e-stop holds), with its holding brakes and an
external disturbance (:class:`ExternalTorque`). The brakes hold before the first effort (``start``), on the drive's
request (``requested``), on the e-stop (``estop``) and when efforts stop coming (``drive_timeout``: the loop's clock
judges when); engaged on every joint at once while any reason holds, a braked joint gets no actuator torque and is
held by its brake's dry friction.

The world never decides when physics runs: its host's clock does (``ros.clocks``; in process, ``step``), through
:meth:`World.advance` and the ``take_*`` methods, each returning what the world writes by it: ``[(port, value), …]``."""

from __future__ import annotations

import operator
from collections.abc import Mapping
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.blocks import spec
from robot_controller.blocks.block import Log
from robot_controller.blocks.values import Array, JointSample, brakes_label, check_effort
from robot_controller.core.model import (
    MAX_DISTURBANCE_NM,
    MujocoPlant,
    PlantVariation,
    check_disturbance,
    steps_per_period,
)

#: What the world writes, in order: (port, value) pairs.
Written = list[tuple[str, Any]]

#: Parameters read once: a change applies on restart.
ON_RESTART = {"physics_rate_hz", "publish_rate_hz", "initial_position", "control_rate_hz"}


class ExternalTorque:
    """The push on the arm: a torque on each joint beside the actuator's (not cut by the brakes; capped at
    ``MAX_DISTURBANCE_NM``) for a span of physics time, asked for on port ``disturbance`` (``[torque_nm…,
    duration_s]``, replacing the one in force) or scheduled by the parameters (``disturbance_*``: from the first
    physics steps at or after ``disturbance_start_s``). Port ``disturbance_applied``, ``[torque_nm…, time_s]``, goes
    with every true state while one acts, and once more, zero, after."""

    def __init__(self, plant: MujocoPlant, params: Mapping[str, Any], log: Log) -> None:
        self.plant = plant
        self.log = log
        n = len(plant.joint_names)
        torque = cfg.per_joint("disturbance_torque_nm", params["disturbance_torque_nm"], n)
        torque = np.clip(torque, -MAX_DISTURBANCE_NM, MAX_DISTURBANCE_NM)
        #: the parameters' one: (torque, start_s, duration_s), None once started (or if there is none: a zero torque
        #: would start nothing, and the physics steps need not ask when it is due)
        self.scheduled: tuple[np.ndarray, float, float] | None = (
            (torque, params["disturbance_start_s"], params["disturbance_duration_s"]) if torque.any() else None
        )
        self.on = False  #: one is being applied (for the line when it ends)
        self.started_s = 0.0  #: physics time it started and ends at
        self.ends_s = 0.0
        self.reported = False  #: the last disturbance applied was not zero

    def take(self, value: Array, *, braked: bool, physics_running: bool) -> None:
        checked = check_disturbance(value.data, len(self.plant.joint_names))
        if isinstance(checked, str):
            self.log.warn(spec.DISTURBANCE.topic, f"{spec.DISTURBANCE.topic} dropped: {checked}")
            return
        torque, duration_s = checked
        if np.any(np.abs(torque) > MAX_DISTURBANCE_NM):
            self.log.warn(
                "disturbance_limit",
                f"{spec.DISTURBANCE.topic} {torque.tolist()} N·m beyond {MAX_DISTURBANCE_NM:g} N·m per joint: capped",
            )
            torque = np.clip(torque, -MAX_DISTURBANCE_NM, MAX_DISTURBANCE_NM)
        self.start(torque, duration_s, braked=braked, physics_running=physics_running)

    def start_scheduled(self) -> None:
        """The parameters' disturbance, once physics time reaches its start (before each batch of physics steps)."""
        if self.scheduled is None or self.plant.time_s + 1e-9 < self.scheduled[1]:
            return
        torque, _, duration_s = self.scheduled
        self.scheduled = None
        self.start(torque, duration_s, braked=False, physics_running=True)

    def start(self, torque: np.ndarray, duration_s: float, *, braked: bool, physics_running: bool) -> None:
        """Apply ``torque`` (N·m per joint) for ``duration_s`` of physics time from now."""
        replaced = self.on
        plant = self.plant
        plant.set_disturbance(torque, duration_s)
        now_s = plant.time_s
        if not plant.disturbance_active:
            if replaced:
                self.on = False
                after = f"after {now_s - self.started_s:.3f} s"
                self.log.info(f"disturbance ended at physics t = {now_s:.3f} s ({after}): replaced by a zero one")
            else:
                self.log.info("disturbance of zero torque or duration received: nothing to apply")
            return
        self.on = True
        self.started_s = now_s
        self.ends_s = now_s + plant.disturbance_remaining_s
        joints = ", ".join(f"{name} {value:g}" for name, value in zip(plant.joint_names, torque, strict=True))
        notes = ["replacing the one in force"] if replaced else []
        if braked:
            notes.append("brakes on: they hold against it")
        if not physics_running:
            notes.append("acting once the physics runs (first command)")
        self.log.info(
            f"disturbance started: {joints} N·m for {duration_s:g} s from physics t = {now_s:.3f} s"
            + (f" ({'; '.join(notes)})" if notes else "")
        )

    def note_end(self) -> None:
        """After the physics stepped: say when a disturbance has run its course."""
        if self.on and not self.plant.disturbance_active:
            self.on = False
            applied = f"applied for {self.ends_s - self.started_s:.3f} s"
            self.log.info(f"disturbance ended at physics t = {self.ends_s:.3f} s ({applied})")

    def applied(self, stamp_s: float) -> Array | None:
        """Port ``disturbance_applied`` for the last physics step: with every state while there is one, then once
        zero; None when there is nothing to say."""
        torque = self.plant.disturbance_torque
        nonzero = bool(torque.any())
        if not (nonzero or self.reported):
            return None
        self.reported = nonzero
        return Array(np.append(torque, stamp_s), "torque_nm")


class World:
    inputs = ("effort", "brake_request", "estop", "disturbance")
    outputs = ("true_state", "brakes", "disturbance_applied")

    def __init__(
        self, params: Mapping[str, Any], log: Log, *, world_waits: bool = False, plant: MujocoPlant | None = None
    ) -> None:
        """:param plant: the arm to use as it is (an in-process loop's, already set up); None: the parameters' (the
        URDF, its variation, at ``initial_position``)"""
        self.log = log
        self.params = dict(params)
        self.variation = PlantVariation.from_params(params)
        if plant is None:
            urdf = resources.resolve_urdf(params["urdf_path"])
            plant = MujocoPlant(urdf, 1.0 / params["physics_rate_hz"], variation=self.variation)
            plant.reset(cfg.per_joint("initial_position", params["initial_position"], len(plant.joint_names)))
        self.plant = plant
        self.joint_names = list(self.plant.joint_names)
        self.joint_count = len(self.joint_names)
        self.effort = np.zeros(self.joint_count)  #: N·m per joint, in force until the next
        self._effort_limits: list[float] = self.plant.effort_limit.tolist()  # N·m per joint, as Python's floats
        self.steps_done = 0  #: physics steps since time 0
        self.physics_dt_ns = round(self.plant.physics_dt * 1e9)
        self.brake_reasons: set[str] = {"start"}  #: why the brakes hold (none: released)
        plant.set_brakes(np.ones(self.joint_count, dtype=bool), params["brake_torque_nm"])
        self.push = ExternalTorque(self.plant, params, log)
        self.request_heard = False  #: the drive's brake request has been heard (a state it latches)
        if not self.variation.nominal:
            log.info(f"the plant differs from its URDF: {self.variation.describe()}")

    def start(self) -> dict[str, Any]:
        return {}  # the brakes' state goes out on its first change (a wall clock repeats it)

    def step(self, t_s: float, inputs: Mapping[str, Any]) -> dict[str, Any]:
        """Take ``inputs`` (they act from the world's time), run physics to ``t_s`` on them, and write the state
        there (each port's last value)."""
        written = self.take(inputs)
        due = round(t_s * 1e9) // self.physics_dt_ns - self.steps_done
        if due > 0:
            self.advance(due)
        written += self.sample(self.time_s)
        return dict(written)

    def wake_period_s(self) -> float | None:
        return None

    @staticmethod
    def check_params(params: Mapping[str, Any]) -> None:
        PlantVariation.from_params(params)  # one payload, not two; every value finite and in range
        steps_per_period(1.0 / params["physics_rate_hz"], 1.0 / params["publish_rate_hz"])
        steps_per_period(1.0 / params["physics_rate_hz"], 1.0 / params["control_rate_hz"])

    def set_params(self, params: Mapping[str, Any], changed: set[str]) -> None:
        if changed & ON_RESTART:
            self.log.warn("on_restart", "physics and publish rates and the initial position apply on restart")

    @property
    def time_ns(self) -> int:
        """Physics time, ns (exact: whole steps)."""
        return self.steps_done * self.physics_dt_ns

    @property
    def time_s(self) -> float:
        return self.steps_done * self.plant.physics_dt

    @property
    def physics_dt(self) -> float:
        return self.plant.physics_dt

    @property
    def estopped(self) -> bool:
        return "estop" in self.brake_reasons

    def braked_for(self, reason: str) -> bool:
        return reason in self.brake_reasons

    def position(self) -> np.ndarray:
        """Each joint's position now, rad (m)."""
        return self.plant.state()[0]

    def brakes_state(self) -> Written:
        """Port ``brakes``: 1 per engaged joint, the reasons in the label (a clock repeats it for late listeners)."""
        engaged = np.full(self.joint_count, 1.0 if self.brake_reasons else 0.0)
        return [("brakes", Array(engaged, brakes_label(self.brake_reasons)))]

    def respawn(self, position: np.ndarray) -> None:
        """Start where an earlier world left the arm (a respawned simulator): braked until the first effort."""
        self.plant.reset(position)
        self.log.warn(
            "respawned",
            f"respawned: the arm is where it was, at {position.tolist()} rad, brakes on until the first command",
        )

    def take(self, inputs: Mapping[str, Any]) -> Written:
        written: Written = []
        for name in self.inputs:
            if name not in inputs:
                continue
            value = inputs[name]
            if name == "effort":
                effort = self.check_effort(value)
                written += [] if effort is None else self.take_effort(effort)
            elif name == "brake_request":
                written += self.take_brake_request(bool(value))
            elif name == "estop":
                released = self.estopped and not value
                written += self.take_estop(bool(value))
                if released:
                    written += self.set_brake("drive_timeout", True)
            else:
                self.take_disturbance(value)
        return written

    def check_effort(self, value: Array) -> np.ndarray | None:
        """Port ``effort``'s value as torques, clamped to the URDF's effort limits; None (and a warning) if bad."""
        limit = self.plant.effort_limit
        data = value.data
        # Every effort of a sound drive: finite and within the limits (a NaN fails the comparison), judged on Python's
        # floats (one per joint: cheaper than numpy's) by builtins alone (no Python call per joint).
        if data.shape == limit.shape and all(map(operator.le, map(abs, data.tolist()), self._effort_limits)):
            return data
        checked = check_effort(data, self.joint_count)
        if isinstance(checked, str):
            self.log.warn(spec.EFFORT.topic, f"{spec.EFFORT.topic} dropped: {checked}")
            return None
        if np.any(np.abs(checked) > limit):
            self.log.warn(
                "effort_limit",
                f"{spec.EFFORT.topic} {checked.tolist()} beyond the URDF's effort limit {limit.tolist()}: clamped",
            )
            checked = np.clip(checked, -limit, limit)
        return checked

    def take_effort(self, effort: np.ndarray) -> Written:
        """The effort in force from now (zero while a brake holds; ignored while the e-stop does): it releases the
        start's and the drive timeout's brakes."""
        written: Written = []
        if self.brake_reasons:  # (released, as on every tick of a running arm, there is nothing to release)
            if self.estopped:
                self.log.warn("estop_effort", "e-stop: efforts ignored until it is released")
                return []
            written = self.set_brake("start", False) + self.set_brake("drive_timeout", False)
        self.effort = np.zeros(self.joint_count) if self.brake_reasons else effort
        return written

    def set_brake(self, reason: str, on: bool) -> Written:
        """Add or remove one reason for the brakes; the brakes' state if their reasons changed: engaged (cutting the
        effort), released, or held for another reason too. An e-stop that finds the brakes held already (the drive
        heard it first and asked for them, or its efforts stopped first) is said all the same: a run is judged on the
        reasons the brakes held for, and the e-stop's are asked for, never a fault."""
        reasons = self.brake_reasons
        if (reason in reasons) == on:
            return []
        before = bool(reasons)
        (reasons.add if on else reasons.discard)(reason)
        engaged = bool(reasons)
        if engaged != before:
            self.plant.set_brakes(np.full(self.joint_count, engaged), self.params["brake_torque_nm"])
            if engaged:
                self.effort = np.zeros(self.joint_count)
        return self.brakes_state()

    def take_brake_request(self, on: bool) -> Written:
        """Port ``brake_request``: the drive's request (a state)."""
        self.request_heard = True
        if on != ("requested" in self.brake_reasons):
            said = "brake requested by the motor: torque off, brakes on" if on else "motor released its brake request"
            self.log.warn(f"brake_request_{on}", said)  # each way its own line
        return self.set_brake("requested", on)

    def take_estop(self, on: bool) -> Written:
        """Port ``estop`` (and the e-stop button): latched until released; released, the brakes wait for the drive's
        next effort (the caller sets ``drive_timeout``: a second message, after the release's)."""
        if on == self.estopped:
            return []
        written = self.set_brake("estop", on)
        self.log.warn(
            f"estop_{on}",  # each way its own line
            "E-STOP: torque off, brakes on (latched until released)"
            if on
            else "e-stop released: brakes release when efforts arrive",
        )
        return written

    def take_disturbance(self, value: Array, *, physics_running: bool = True) -> None:
        """Port ``disturbance``: applied from now (``physics_running``: the clock runs physics already)."""
        self.push.take(value, braked=bool(self.brake_reasons), physics_running=physics_running)

    def advance(self, steps: int) -> None:
        """Run ``steps`` physics steps on the effort in force (the parameters' disturbance starting if due)."""
        self.push.start_scheduled()
        self.plant.step(self.effort, steps)
        self.steps_done += steps
        self.push.note_end()

    def true_state(self, stamp_s: float) -> JointSample:
        """The true state now, stamped ``stamp_s``, with the effort applied (zero while braked): port
        ``true_state``'s value, for a host that reads nothing else of the world's (the in-process loop)."""
        position, velocity = self.plant.state()
        # The effort in force is replaced by each take, never written into: the sample may hold it as it is.
        effort = np.zeros(self.joint_count) if self.brake_reasons else self.effort
        return JointSample(stamp_s, self.joint_names, position, velocity, effort)

    def sample(self, stamp_s: float) -> Written:
        """The true state now, stamped ``stamp_s`` (:meth:`true_state`), and the disturbance applied in the last
        physics step if there is one to say."""
        written: Written = [("true_state", self.true_state(stamp_s))]
        applied = self.push.applied(stamp_s)
        if applied is not None:
            written.append(("disturbance_applied", applied))
        return written
