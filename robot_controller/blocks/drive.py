"""The drive (the graph's ``motor_node``): each command's torque is saturated to ``±torque_max`` (and lagged, if set)
and written as the effort; one older than ``max_command_age_s`` is dropped. Like a real drive it stops on its own (no
valid command for ``command_timeout_s``, or the e-stop): zero torque and a brake request. Receipts go out once a
second, rows of ``[receipt_time_s, command…]``: when each command arrived, for the controller's latency guard."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from robot_controller import resources
from robot_controller.blocks.block import Log
from robot_controller.blocks.values import Array, check_effort
from robot_controller.core.errors import ConfigError
from robot_controller.core.metrics import EFFORT_UNITS, in_units
from robot_controller.core.model import Actuator, effort_limits, joint_names, load_model
from robot_controller.core.model.mujoco_model import joint_units
from robot_controller.parameters.torque_limits import torque_limit

RECEIPTS_PERIOD_S = 1.0
# The drive's own pause up to this long (a machine-wide stall) is not counted as the controller's silence.
MAX_EXCUSED_GAP_S = 0.2
# Stopped for a timeout (or before the first command), the drive restarts after this many timely commands in a row.
TIMELY_COMMANDS_TO_START = 5


class Drive:
    inputs = ("command", "estop")
    outputs = ("effort", "brake_request", "command_receipts")

    def __init__(self, params: Mapping[str, Any], log: Log, *, world_waits: bool = False) -> None:
        """:param world_waits: the loop's clock waits for each effort (sim time, the paced world): every command is
        timely, and the first starts the drive (waiting for more, it would wait for ever)."""
        self.log = log
        model = load_model(resources.resolve_urdf(params["urdf_path"]))
        self.joint_count = len(joint_names(model))
        self.effort_limit = effort_limits(model)
        self.effort_units = [EFFORT_UNITS[unit] for unit in joint_units(model)]  # N·m, or N on a prismatic joint
        self.params = dict(params)
        self.commands_to_start = 1 if world_waits else TIMELY_COMMANDS_TO_START
        self.actuator = self._make_actuator(params)
        self.last_command_s: float | None = None
        self.stopped_for: str | None = None  # "timeout" or "estop" while stopped
        self.estop = False
        self.last_check_s: float | None = None
        self.timely_run = 0  #: timely commands in a row while stopped for a timeout or before the first
        self.excused_s = 0.0  #: of the silence since the last command, time this process itself was not running
        self.receipts: list[float] = []  # flat rows of [receipt_time_s, command…]
        self.next_receipts_s: float | None = None
        log.info(
            f"motor: torque limit ±{in_units(self.actuator.torque_max, self.effort_units)}, "
            f"lag {self.actuator.lag_time_constant_s:g} s"
        )

    def _make_actuator(self, params: Mapping[str, Any]) -> Actuator:
        torque_max = torque_limit(params, self.joint_count)
        if np.any(torque_max > self.effort_limit):
            raise ConfigError(
                f"torque_max: {in_units(torque_max, self.effort_units)} exceeds the URDF's effort limit "
                f"{in_units(self.effort_limit, self.effort_units)} (it may lower the drive's limit, never raise it)"
            )
        return Actuator(torque_max, params["lag_time_constant_s"])

    def start(self) -> dict[str, Any]:
        return {"brake_request": False}  # latched: a (re)started world learns it

    def wake_period_s(self) -> float | None:
        return self.params["command_timeout_s"] / 2

    def check_params(self, params: Mapping[str, Any]) -> None:
        self._make_actuator(params)

    def set_params(self, params: Mapping[str, Any], changed: set[str]) -> None:
        self.params = dict(params)
        self.actuator = self._make_actuator(params)

    def step(self, t_s: float, inputs: Mapping[str, Any]) -> dict[str, Any]:
        # Each of the take methods returns a new dict: the step's own, added to, not copied.
        if not inputs:
            out = self.check_timeout(t_s)
        elif "estop" in inputs:
            out = self.take_estop(bool(inputs["estop"]))
            if "command" in inputs:
                out.update(self.take_command(t_s, inputs["command"]))
        else:  # a command alone, each tick's
            out = self.take_command(t_s, inputs["command"]) if "command" in inputs else {}
        if self.next_receipts_s is None or t_s >= self.next_receipts_s:
            if self.next_receipts_s is not None:
                out.update(self.finish())
            self.next_receipts_s = t_s + RECEIPTS_PERIOD_S
        return out

    def take_command(self, now_s: float, command: Array) -> dict[str, Any]:
        checked = check_effort(command.data, self.joint_count)
        if isinstance(checked, str):
            self.log.warn("command", f"command dropped: {checked}")
            return {}
        if self.estop:
            return {}
        tick_s = command.tick_s
        self.receipts += [now_s, *command.data.tolist()]  # a late command too: its delay is what the controller learns
        max_age_s = self.params["max_command_age_s"]
        if tick_s is not None and now_s - tick_s > max_age_s:
            self.log.warn(
                "late_command",
                f"command dropped: issued {(now_s - tick_s) * 1e3:.0f} ms ago "
                f"(max_command_age_s {max_age_s:g}): a late command is no command",
            )
            self.timely_run = 0
            return {}
        if self.stopped_for == "timeout" or self.last_command_s is None:
            # Stopped (or not started): only a steady stream of timely commands moves the arm.
            self.timely_run += 1
            if self.timely_run < self.commands_to_start:
                return {}
        self.timely_run = 0
        out: dict[str, Any] = {}
        if self.stopped_for == "timeout":
            self.log.info("commands back: brake request released")
            out["brake_request"] = False
            self.stopped_for = None
        dt = 0.0 if self.last_command_s is None else now_s - self.last_command_s
        self.last_command_s = now_s
        self.excused_s = 0.0
        # The tick goes on: a paced world drops an effort come too late.
        # (Labelled with its command's own label and tick: neither formatted again nor read.)
        out["effort"] = Array(self.actuator.apply(checked, dt), "" if tick_s is None else command.label, None, tick_s)
        return out

    def check_timeout(self, now_s: float) -> dict[str, Any]:
        own_gap_s = 0.0 if self.last_check_s is None else now_s - self.last_check_s
        self.last_check_s = now_s
        if self.stopped_for is not None or self.last_command_s is None:
            return {}  # already stopped, or no command yet (the brakes are on from start-up)
        timeout_s = self.params["command_timeout_s"]
        if timeout_s < own_gap_s <= MAX_EXCUSED_GAP_S:
            # This process was not running: the commands the pause held back are on their way, not silent.
            self.excused_s += own_gap_s - timeout_s / 2
        silent_s = now_s - self.last_command_s - self.excused_s
        if silent_s <= timeout_s:
            return {}
        self.log.warn(
            "timeout", f"no valid commands for {silent_s * 1e3:.0f} ms: zero torque, brake requested (category 0)"
        )
        return self.stop("timeout")

    def stop(self, reason: str) -> dict[str, Any]:
        """Zero torque and the brakes, the brake request first: it must never reach an unbraked, loaded arm."""
        self.stopped_for = reason
        self.actuator.reset()
        return {"brake_request": True, "effort": Array(np.zeros(self.joint_count))}

    def take_estop(self, on: bool) -> dict[str, Any]:
        if on == self.estop:
            return {}
        self.estop = on
        if on:
            self.log.warn("estop", "E-STOP: zero torque, brake requested (latched until released)")
            return self.stop("estop")
        self.log.info("e-stop released: forwarding commands again")
        self.stopped_for = None
        self.last_command_s = None
        return {"brake_request": False}

    def finish(self) -> dict[str, Any]:
        """The receipts since the last (at the end too: the last second's)."""
        if not self.receipts:
            return {}
        receipts, self.receipts = np.asarray(self.receipts), []
        return {"command_receipts": Array(receipts, "commands", row=("receipt_time_s,command", 1 + self.joint_count))}
