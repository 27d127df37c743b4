"""The loop in one process, no ROS: the graph's blocks (the world, and the sensor and the drive its configuration
names) wired as the graph wires them, with the planner and the controller, stepped in order each control period. For
tuning, sweeps, tests, and as the ideal the ROS graph is measured against (no transport delay, perfectly periodic
ticks): each value reaches its reader at the tick it was written, as in the graph on sim time."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from robot_controller.blocks.block import Block
from robot_controller.blocks.controller import position_noise
from robot_controller.blocks.values import JointSample, at_tick
from robot_controller.blocks.world import World
from robot_controller.core import metrics
from robot_controller.core.controller import JointController, Status
from robot_controller.core.controller.state_layout import STATUS_CODES
from robot_controller.core.model import steps_per_period

# Ticks that command nothing once a controlled stop is over: the drive brakes the arm.
BRAKING_STATUSES = (Status.SENSOR_LOST, Status.LAW_STOPPED)
#: What the loop records at each tick, one ``(ticks, joints)`` array each.
RECORDED = ("reference", "measured", "true_position", "true_velocity", "command", "applied")


@dataclass
class LoopResult:
    """Per-tick record of a run; arrays are ``(ticks, joints)`` except ``tick_time_s``."""

    tick_time_s: np.ndarray
    reference: np.ndarray
    measured: np.ndarray
    true_position: np.ndarray
    true_velocity: np.ndarray
    command: np.ndarray
    applied: np.ndarray
    joint_names: list[str]  #: the columns' joints (the plant's order)
    joint_units: list[str]  #: "rad" or "m" per joint
    law_fault: str | None  #: what a plugin law did wrong (its one line), if it did
    adapted_armature_kgm2: list[float]  #: kg·m² per joint, what the inertia adaptation had learnt at the end
    #: each tick's status, its code on the state topic (``state_layout.STATUS_CODES``); empty: not recorded
    status_code: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def tracking_metrics(self, warmup_s: float = metrics.WARMUP_S) -> dict[str, Any]:
        """Tracking per joint and the worst joint's, with ``joint_names``, as ``metrics.json`` has them."""
        q = self.reference, self.true_position, self.measured
        out = metrics.tracking_metrics(self.tick_time_s, *q, warmup_s=warmup_s, units=self.joint_units)
        return {"joint_names": list(self.joint_names), **out, "adapted_armature_kgm2": list(self.adapted_armature_kgm2)}


def run_loop(
    *,
    world: World,
    controller: JointController,
    sensor: Block,
    drive: Block,
    planner: Block,
    duration_s: float,
    control_period_s: float,
    planner_period_s: float,
    measurement_delay_s: float = 0.0,
    delay_unstamped: bool = False,
    command_gain: float = 1.0,
) -> LoopResult:
    """``duration_s`` seconds of the loop, each tick: the planner publishes if its period has come round, the sensor
    reads the world's true state, the controller computes, the drive turns the command into the effort the world
    holds over the next control period.

    :param world: stepped here as the graph's sim-time clock steps it
    :param planner: stepped on its period's grid; its reference taken at the tick (its sample time: the tick's)
    :param measurement_delay_s: what the graph's transport adds between physics and sensor: the sensor reads the
        true state that many seconds old, stamped with its own time
    :param delay_unstamped: stamped when it arrives instead, so the controller cannot compensate
    :param command_gain: the drive is given this many times the command (a drive that is stronger than its model)
    """
    n_steps = steps_per_period(world.physics_dt, control_period_s)
    ticks = int(round(duration_s / control_period_s))
    planner_every = max(1, int(round(planner_period_s / control_period_s)))
    names, n = list(world.joint_names), len(world.joint_names)
    delay_steps = int(round(measurement_delay_s / world.physics_dt))
    history: list[tuple[float, np.ndarray, np.ndarray]] = []  # (time, q, v) per physics step
    rows = np.zeros((len(RECORDED), ticks, n))
    # Each record's rows bound once: a row written from its array, not a tuple of six converted each tick.
    reference_rows, measured_rows, true_position_rows, true_velocity_rows, command_rows, applied_rows = rows
    times = np.arange(ticks) * control_period_s
    status_codes = np.zeros(ticks)
    braked = False
    position = np.zeros(n)
    effort = np.zeros(n)
    for k, t in enumerate(times.tolist()):  # Python floats: the controller's scalar time arithmetic is cheaper
        if k % planner_every == 0:
            sample = planner.step(t, {})["reference"].data
            controller.set_reference(t, sample[:n], sample[n : 2 * n], sample[2 * n : 3 * n])
        # The state the last physics steps left, stamped with the tick: port ``true_state``'s value as it is.
        true_state = world.true_state(t)
        true_position, true_velocity = true_state.position, true_state.velocity
        stamp = t
        if delay_steps:
            history.append((t, true_position, true_velocity))
            stamp, seen_q, seen_v = history[max(0, len(history) - 1 - delay_steps)]
            del history[: max(0, len(history) - 1 - delay_steps)]
            true_state = JointSample(t, world.joint_names, seen_q, seen_v)
        # The sensor reads, at the tick, what reaches it (late by the transport's delay); its reading is of the
        # state at ``stamp``, that much older than the stamp it gives (unless it cannot tell: ``delay_unstamped``).
        reading = sensor.step(t, {"true_state": true_state}).get("reading")
        if reading is not None:
            position = reading.position
            sample_s = (
                reading.stamp_s if stamp == t else stamp if reading.stamp_s == t else reading.stamp_s - (t - stamp)
            )
            stamp_s = t if delay_unstamped else sample_s
            controller.set_measurement(stamp_s, t, position, reading.velocity, position_noise(reading))
        out = controller.update(t)
        command = out.command
        inputs: dict[str, Any] = {}
        if not braked and out.status in BRAKING_STATUSES:
            inputs["brake_request"] = True  # as the drive's command timeout asks the graph's world
            braked = True
        given = command if command_gain == 1.0 else command_gain * command
        written = drive.step(t, {"command": at_tick(given, t)}).get("effort")
        if written is not None:
            effort = written.data
            inputs["effort"] = written
        world.take(inputs)
        if delay_steps:
            for step in range(1, n_steps + 1):
                world.advance(1)
                if step < n_steps:
                    state = world.true_state(t + step * world.physics_dt)
                    history.append((state.stamp_s, state.position, state.velocity))
        else:
            world.advance(n_steps)
        reference_rows[k] = out.reference
        measured_rows[k] = position
        true_position_rows[k] = true_position
        true_velocity_rows[k] = true_velocity
        command_rows[k] = command
        applied_rows[k] = effort
        status_codes[k] = STATUS_CODES[out.status]
    fault, inertia = controller.law_fault, getattr(controller, "inertia", None)  # (a stand-in may have none)
    return LoopResult(
        tick_time_s=times,
        joint_names=names,
        joint_units=list(world.plant.joint_units),
        law_fault=None if fault is None else fault.line(),
        adapted_armature_kgm2=[0.0] * n if inertia is None else inertia.armature.tolist(),
        status_code=status_codes,
        **dict(zip(RECORDED, rows, strict=True)),
    )
