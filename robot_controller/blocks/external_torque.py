"""The world's external disturbance: a torque on each joint beside the actuator's (not cut by the brakes; capped at
``MAX_DISTURBANCE_NM``) for a span of physics time, asked for on port ``disturbance`` (``[torque_nm…, duration_s]``,
replacing the one in force) or scheduled by the parameters (``disturbance_*``: from the first physics steps at or
after ``disturbance_start_s``). Port ``disturbance_applied``, ``[torque_nm…, time_s]``, goes with every true state
while one acts, and once more, zero, after."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.blocks import spec
from robot_controller.blocks.block import Log
from robot_controller.blocks.values import Array
from robot_controller.core.model import MAX_DISTURBANCE_NM, MujocoPlant, check_disturbance


class ExternalTorque:
    """The push on the arm: taken like an effort, applied in the physics beside it."""

    def __init__(self, plant: MujocoPlant, params: Mapping[str, Any], log: Log) -> None:
        self.plant = plant
        self.log = log
        n = len(plant.joint_names)
        torque = cfg.per_joint("disturbance_torque_nm", params["disturbance_torque_nm"], n)
        #: the parameters' one: (torque, start_s, duration_s), None once started (or if there is none)
        self.scheduled: tuple[np.ndarray, float, float] | None = (
            np.clip(torque, -MAX_DISTURBANCE_NM, MAX_DISTURBANCE_NM),
            params["disturbance_start_s"],
            params["disturbance_duration_s"],
        )
        self.on = False  #: one is being applied (for the line when it ends)
        self.started_s = 0.0  #: physics time it started and ends at
        self.ends_s = 0.0
        self.reported = False  #: the last disturbance applied was not zero

    def take(self, value: Array, *, braked: bool, physics_running: bool) -> None:
        """Port ``disturbance``: checked, capped, applied from now."""
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
        if np.any(torque != 0.0):
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
