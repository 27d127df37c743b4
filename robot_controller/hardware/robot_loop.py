"""The loop on a robot that keeps its own clock: each state the robot sends is a tick. The planner and the controller
are the blocks the simulated loop steps (``blocks.wiring``); in place of the world, the sensor and the drive there is
the robot: its state is the reading (the robot's own ``q``, also what the arm truly did), and the controller's torque,
through the :class:`~robot_controller.hardware.torque_guard.TorqueGuard`, less gravity (the robot adds its own), is
the command. The arm starts where it stands; the planner blends from there onto its motion.

A tick's own time (from the state's arrival to the command's writing) is what the robot's 1 ms budget judges; a
state that comes more than a period after the last is a missed cycle by the robot's count. A reflex or a lost link
ends the run (:class:`~robot_controller.hardware.franka_arm.RobotFault`), as does a controller that ends its motion
(the braking statuses): the robot then holds where it is."""

from __future__ import annotations

import contextlib
import gc
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.blocks.block import Lines
from robot_controller.blocks.planner import Planner
from robot_controller.blocks.wiring import BRAKING_STATUSES, RECORDED, LoopResult
from robot_controller.core.controller import JointController
from robot_controller.core.model import joint_limits
from robot_controller.core.model.velocity_envelope import FR3_VELOCITY_ENVELOPE
from robot_controller.hardware.franka_arm import RobotFault, RobotReading
from robot_controller.hardware.robot_timing import timing_figures
from robot_controller.hardware.torque_guard import (
    CONTROLLER_RATE_SHARE,
    FRANKA_TORQUE_RATE_NM_S,
    RobotLimits,
    TorqueGuard,
)
from robot_controller.parameters import consistency
from robot_controller.parameters.builders import arm_model, given
from robot_controller.parameters.torque_limits import torque_limit
from robot_controller.ros.scheduling import LOOP_NICE

#: s the controller holds the arm where it stands before the motion is blended in. A robot's first periods under
#: torque control are its least regular (the stand-in's came 1.2-2.3 ms apart and it skipped late commands), and the
#: controller's first ticks its slowest: a torque that barely changes there has nothing to lose. (Blended in at once,
#: the torque ramped at the rate limit through them, and the robot refused a step.)
HOLD_S = 0.3


class Robot(Protocol):
    """What the loop needs of a robot (``FrankaArm`` is one)."""

    def position(self) -> np.ndarray: ...

    def start(self) -> RobotReading: ...

    def read(self) -> RobotReading: ...

    def write(self, torque_nm: np.ndarray) -> None: ...

    def finish(self) -> None: ...


@dataclass
class RobotRun:
    """A run on the robot: the per-tick record (``loop``, as the simulated loop's), and how the robot's clock went."""

    loop: LoopResult
    tick_compute_s: np.ndarray  #: per tick, from the state's arrival to the command's writing, s
    missed: int  #: periods that passed without a state (by the robot's clock)
    success_rate: np.ndarray  #: per tick, the robot's ``control_command_success_rate``
    guard_acted: list[int]  #: per joint, the ticks the guard changed the controller's torque
    fault: RobotFault | None  #: what ended the run early, if anything did
    ended_by: str | None  #: a controller status that ended the motion, if one did

    def timing(self) -> dict[str, float]:
        """The tick's own time against the period, the periods missed and the commands the robot took in time
        (``robot_timing.timing_figures``)."""
        return timing_figures(self.tick_compute_s, self.success_rate, self.missed)


@dataclass
class RobotLoop:
    """The planner, the controller and the guard for a robot, built from the stack's parameters."""

    planner: Planner
    controller: JointController
    guard: TorqueGuard
    dynamics: Any  #: the controller's arm model (its ``gravity(q)`` is what the robot adds back)
    joint_names: list[str]

    def command(self, t_s: float, reading: RobotReading) -> Tick:
        """The tick at ``t_s`` on ``reading`` (its reference given already): the controller's output, the torque it
        asks for (gravity included) and what goes to the robot (through the guard, gravity left out)."""
        self.controller.set_measurement(t_s, t_s, reading.position, reading.velocity)
        out = self.controller.update(t_s)
        gravity = self.dynamics.gravity(reading.position)
        inertia = self.dynamics.mass_matrix(reading.position).diagonal()
        total = np.asarray(out.command if out.command is not None else gravity, float)
        sent = self.guard(total, gravity, reading.position, reading.velocity, inertia, reading.commanded_nm)
        return Tick(out, total, sent, gravity)

    def damp(self, reading: RobotReading) -> np.ndarray:
        """The torque to send that brings every joint to rest from ``reading`` (damped, the robot holding gravity),
        through the guard: a stop that cannot speed any joint up."""
        gravity = self.dynamics.gravity(reading.position)
        inertia = self.dynamics.mass_matrix(reading.position).diagonal()
        settings = self.guard.settings
        brake = np.clip(-settings.braking_nms * reading.velocity, -self.guard.brake_nm, self.guard.brake_nm)
        return self.guard(gravity + brake, gravity, reading.position, reading.velocity, inertia, reading.commanded_nm)

    def run(self, robot: Robot, duration_s: float) -> RobotRun:
        """``duration_s`` s of the robot's time, a tick per state it sends, the planner stepped here."""
        ticks = int(round(duration_s / self.controller.config.control_period_s))
        n = len(self.joint_names)
        rows = np.full((len(RECORDED), ticks, n), np.nan)
        reference_rows, measured_rows, position_rows, velocity_rows, command_rows, applied_rows = rows
        times, compute, rates = np.full(ticks, np.nan), np.zeros(ticks), np.zeros(ticks)
        missed, fault, ended_by, k = 0, None, None, 0
        with loop_thread():
            try:
                # The controller holds the arm where it stands for HOLD_S, then the motion is blended in from there
                # (planned now, before the robot's clock starts: it takes a few ms). See HOLD_S.
                standing = robot.position()
                still = np.zeros(n)
                self.planner.start_from(standing, HOLD_S)
                reading = robot.start()
                while k < ticks:
                    arrived = time.perf_counter()
                    t = reading.time_s
                    missed += reading.missed
                    if t < HOLD_S:
                        sample = np.concatenate((standing, still, still, [t]))
                    else:
                        sample = self.planner.step(t, {})["reference"].data  # (at the robot's rate: every tick)
                    self.controller.set_reference(t, sample[:n], sample[n : 2 * n], sample[2 * n : 3 * n])
                    tick = self.command(t, reading)
                    robot.write(tick.sent_nm)
                    compute[k] = time.perf_counter() - arrived
                    times[k], rates[k] = t, reading.success_rate
                    measured_rows[k] = position_rows[k] = reading.position
                    velocity_rows[k] = reading.velocity
                    reference_rows[k] = sample[:n]
                    command_rows[k] = tick.total_nm
                    applied_rows[k] = tick.sent_nm + tick.gravity_nm
                    k += 1
                    if tick.out.status in BRAKING_STATUSES:
                        ended_by = str(tick.out.status)
                        break
                    reading = robot.read()
            except RobotFault as exc:
                fault = without_frames(exc)
            finally:
                if fault is None:
                    robot.finish()
        loop = LoopResult(
            tick_time_s=times[:k],
            reference=reference_rows[:k],
            measured=measured_rows[:k],
            true_position=position_rows[:k],
            true_velocity=velocity_rows[:k],
            command=command_rows[:k],
            applied=applied_rows[:k],
            joint_names=list(self.joint_names),
            joint_units=["rad"] * n,
            law_fault=None,
            adapted_armature_kgm2=[0.0] * n,
        )
        return RobotRun(loop, compute[:k], missed, rates[:k], self.guard.acted.tolist(), fault, ended_by)


@dataclass
class Tick:
    """One tick's output (``out``), the torque it asks for (``total_nm``, gravity included), what goes to the robot
    (``sent_nm``: through the guard, gravity left out) and the gravity the robot adds (``gravity_nm``)."""

    out: Any
    total_nm: np.ndarray
    sent_nm: np.ndarray
    gravity_nm: np.ndarray


def without_frames(fault: RobotFault) -> RobotFault:
    """``fault`` without its traceback: its frames hold the robot's connection open, and libfranka's next connect to
    the robot would wait for it for good."""
    fault = fault.with_traceback(None)
    fault.__context__ = None
    return fault


@contextlib.contextmanager
def loop_thread() -> Iterator[None]:
    """The calling thread made fit for the robot's clock, and put back after:

    - no garbage collector pass: over a large heap (a test session's) one took over 20 ms, 20 periods without a
      command, and the robot stopped (communication_constraints_violation). The loop makes no cycles of its own; what
      the heap holds now is frozen out of the collector's way;
    - nice -10 (where the host lets it), as the graph's loop processes run: the robot's clock waits for nobody (at
      nice 0 beside a busy test session, 20 late commands in a row stopped the robot)."""
    collecting = gc.isenabled()
    gc.disable()
    gc.freeze()
    niceness = os.getpriority(os.PRIO_PROCESS, 0)
    with contextlib.suppress(OSError):
        os.setpriority(os.PRIO_PROCESS, 0, min(niceness, LOOP_NICE))
    try:
        yield
    finally:
        gc.unfreeze()
        if collecting:
            gc.enable()
        with contextlib.suppress(OSError):
            os.setpriority(os.PRIO_PROCESS, 0, niceness)


def robot_loop(params: cfg.Params, rotor_inertia_kgm2: float, period_s: float = 0.001) -> RobotLoop:
    """The loop for a robot ticking every ``period_s`` from the stack's parameters: the controller and the planner at
    the robot's rate, the controller's torque slewed within the robot's rate limit (:data:`CONTROLLER_RATE_SHARE`),
    its model the URDF's plus ``rotor_inertia_kgm2`` on every joint (the reflected rotor inertia a real arm's URDF
    leaves out) unless ``model_inertia`` gives it."""
    rate_hz = 1.0 / period_s
    slew = CONTROLLER_RATE_SHARE * FRANKA_TORQUE_RATE_NM_S
    given_slew = params["pid_controller"]["slew_rate_limit"]
    params = cfg.merge(
        params,
        {
            "pid_controller": {"control_rate_hz": rate_hz, "slew_rate_limit": min(given_slew or slew, slew)},
            "trajectory_planner": {"publish_rate_hz": rate_hz},
        },
    )
    ctrl = dict(params["pid_controller"])
    dynamics = arm_model(ctrl)
    n = len(dynamics.joint_names)
    if rotor_inertia_kgm2 and not given(ctrl.get("model_inertia")):
        ctrl["model_inertia"] = [float(x) for x in np.diag(dynamics.mass_matrix(np.zeros(n))) + rotor_inertia_kgm2]
        params = cfg.merge(params, {"pid_controller": {"model_inertia": ctrl["model_inertia"]}})
        dynamics = arm_model(ctrl)
    controller = JointController(cfg.controller_config(ctrl, n), n, dynamics)
    planner = Planner(consistency.with_controller_model(params)["trajectory_planner"], Lines())
    planner.start()
    limits = joint_limits(resources.resolve_urdf(ctrl["urdf_path"]))
    envelope = FR3_VELOCITY_ENVELOPE
    robot_limits = RobotLimits(
        torque_nm=np.asarray(torque_limit(ctrl, n), float),
        velocity_rad_s=limits.velocity,
        # The URDF's range within the robot's own (its reflexes judge by theirs)
        lower_rad=np.maximum(limits.lower, envelope.lower_rad),
        upper_rad=np.minimum(limits.upper, envelope.upper_rad),
        envelope=envelope,
    )
    guard = TorqueGuard(robot_limits, period_s)
    return RobotLoop(planner, controller, guard, dynamics, list(limits.joint_names))
