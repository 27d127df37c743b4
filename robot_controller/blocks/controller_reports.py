"""What the controller block says: the law and gains in force, a line per change of the loop's state, a failed law's
line, a joint cut by its limit, the inertia adaptation's gain changes, the start's waits, the tutorial's
once-a-period line, and every term of each tick as the row of its port ``state`` (``core.controller.state_layout``).
Times are the tick's unless a method is given another clock."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable
from typing import Any

import numpy as np

from robot_controller.blocks import spec
from robot_controller.blocks.block import Log
from robot_controller.core.controller import ControlOutput, JointController, Status, state_layout
from robot_controller.core.controller.inertia_adaptation import SAID_STEP
from robot_controller.core.metrics import EFFORT_UNITS

# A start's normal wait for the first reading or reference sample lasts less than this (s); past it, a warning.
START_PATIENCE_S = 10.0
# A joint whose command the limit cuts this long without a break (s, the tick's clock) is said, once per run.
SATURATION_SAID_AFTER_S = 0.2
# The inertia adaptation's gain changes are said at most this often (s, the tick's clock): it moves a factor a few
# times a second while it learns, and each line is a gain change a reader may want to see, not each step.
ADAPTATION_SAID_EVERY_S = 1.0
#: The exit code of a controller whose own law failed and whose stop is over (the launcher names it).
LAW_STOPPED_EXIT_CODE = 3


class SaturationWatch:
    """Which joints' commands have been cut by their limit for ``SATURATION_SAID_AFTER_S`` in a row, each once."""

    def __init__(self, joint_count: int) -> None:
        self.since_s = np.full(joint_count, np.nan)  # when each joint's current run of cut ticks began
        self.said = np.zeros(joint_count, dtype=bool)

    def newly_long(self, now_s: float, saturated: np.ndarray) -> list[int]:
        """The joints to say now: saturated for long enough and not said before."""
        if not np.count_nonzero(saturated):  # most ticks
            self.since_s.fill(np.nan)
            return []
        cut = np.asarray(saturated) > 0.5
        self.since_s = np.where(cut, np.fmin(self.since_s, now_s), np.nan)
        long = cut & ~self.said & (now_s - self.since_s >= SATURATION_SAID_AFTER_S - 1e-9)
        self.said |= long
        return np.flatnonzero(long).tolist()


class StartWaits:
    """What the controller waits for at start (its first reading; where the world waits, its first reference
    sample): said once as information, for every start begins so; a warning once the wait has lasted
    ``START_PATIENCE_S``, for then the node it waits for is not running or not heard. Timed on the clock its caller
    gives (a wall clock: sim time stands still then)."""

    def __init__(self, log: Log) -> None:
        self.log = log
        self.since: dict[str, float] = {}  # s each wait began

    def waiting(self, key: str, what: str, now_s: float) -> None:
        if key not in self.since:
            self.since[key] = now_s
            self.log.info(f"waiting for {what}")
        elif now_s - self.since[key] > START_PATIENCE_S:
            waited = now_s - self.since[key]
            self.log.warn(
                f"start_{key}", f"still waiting after {waited:.0f} s for {what}: is that node running, on this domain?"
            )


def law_in_force_line(controller: Any, margin: int | None, rate_hz: float) -> str:
    """The controller's law line and ``margin``, the delay margin last checked in full (None: a law of one's own)."""
    in_force = controller.law_in_force()
    if margin is not None:
        periods = "control period" if margin == 1 else "control periods"
        in_force += f"; delay margin {margin} {periods} ({margin * 1e3 / rate_hz:g} ms) beyond what the stamps show"
        inertia = getattr(controller, "inertia", None)
        if inertia is not None and np.any(inertia.scale != 1.0):
            needed = controller.config.min_delay_margin_periods
            in_force += (
                f" as designed, at least {needed} with the adaptive factors on the inertia learnt"
                if needed > 0
                else " as designed, unchecked with the adaptive factors (min_delay_margin_periods 0)"
            )
    return in_force


class Reports:
    """The controller's lines and its state row. ``law_in_force`` is the line its host shows as the read-only
    parameter of that name; ``law_fault_line`` the failed law's line, once said."""

    def __init__(self, log: Log, controller: JointController, world_waits: bool) -> None:
        self.log = log
        self.controller = controller
        self.joint_names = list(controller.dynamics.joint_names)
        self.joint_units = list(controller.dynamics.joint_units)
        self.joint_count = len(self.joint_names)
        self.world_waits = world_waits
        self.last_status: Status | None = None
        self.faults_seen = False  # "again" only after a fault: the start's blend ends "on the trajectory"
        self.saturation = SaturationWatch(self.joint_count)
        plugin = controller.plugin
        # The law's extra terms on the state after the standard blocks, then the armature the inertia adaptation learnt.
        taken = {*state_layout.FIELDS, *state_layout.HEADER, state_layout.ADAPTED_ARMATURE}
        self.extra_terms = tuple(name for name in (plugin.extra_terms if plugin else ()) if name not in taken)
        self.inertia = controller.inertia
        adaptation = () if self.inertia is None else (state_layout.ADAPTED_ARMATURE,)
        #: the state row's blocks, (label, size) each: its layout
        self.state_blocks = tuple((name, 1) for name in state_layout.HEADER) + tuple(
            (name, self.joint_count) for name in (*state_layout.FIELDS, *self.extra_terms, *adaptation)
        )
        self.next_adaptation_s = -np.inf  # the tick's clock: when its gain changes may be said again
        self.said_scale = np.ones(self.joint_count)  # the factors on the designed gains last said
        self.margin: int | None = None  # the delay margin law_in_force last stated
        self.rate_hz = 0.0
        self.law_in_force = ""
        self.law_fault_line: str | None = None

    def log_gains(self, margin: int | None, rate_hz: float) -> None:
        """The law and gains in force and ``margin``, the control periods of unaccounted delay they survive (found
        when the change was checked), in the log and as ``law_in_force``."""
        self.margin, self.rate_hz = margin, rate_hz
        self.law_in_force = law_in_force_line(self.controller, margin, rate_hz)
        world = ", on sim time" if self.world_waits else ""
        self.log.info(f"{self.law_in_force}; at {rate_hz:g} Hz on {self.joint_names}" + world)

    def say_adaptation(self, now_s: float) -> None:
        """The inertia adaptation's gain changes since they were last said (a factor moved over SAID_STEP), one line
        for all the steps in an interval of ``ADAPTATION_SAID_EVERY_S``, and ``law_in_force`` stated again with them.
        The delay margin stated stays the one last checked in full (up to a second on a 7-joint arm)."""
        if self.inertia is None or now_s < self.next_adaptation_s:
            return
        self.next_adaptation_s = now_s + ADAPTATION_SAID_EVERY_S
        if not self.inertia.notes():  # (its lines, one per step of SAID_STEP: said here as one per interval)
            return
        scale, armature, said = self.inertia.scale, self.inertia.armature, self.said_scale
        moved = np.flatnonzero(np.abs(scale - said) > SAID_STEP * said)
        if moved.size:
            names = self.joint_names
            changes = ", ".join(
                f"{names[j]} ×{scale[j]:.3g} (was ×{said[j]:.3g}; armature {armature[j]:.3g} kg·m²)" for j in moved
            )
            self.log.info(f"inertia adaptation: gains in force now the design {changes}")
            self.said_scale = np.where(np.isin(np.arange(len(scale)), moved), scale, said)
        self.law_in_force = law_in_force_line(self.controller, self.margin, self.rate_hz)

    def status_changed(self, status: Status, first_tick_s: float) -> None:
        """One log line when the loop's state changes (faults, stops, recovery)."""
        config = self.controller.config
        before, self.last_status = self.last_status, status
        warnings = {
            Status.WATCHDOG: f"no valid {spec.READING.topic} for over {config.watchdog_periods} periods: "
            "controlled stop on the arm model's estimate (category 2)",
            Status.SENSOR_LOST: (
                f"no valid {spec.READING.topic}, and the world went on without this controller's commands: its drive's "
                "brakes hold the arm (category 0); no command until a fresh reading, then re-acquiring from it"
                if self.world_waits
                else f"no valid {spec.READING.topic} for {config.sensor_timeout_s:g} s: no more commands, torque off, "
                "the brake holds (category 1)"
            ),
            Status.REFERENCE_LOST: f"no {spec.REFERENCE.topic} sample for too long: controlled stop, holding",
            Status.STOPPED: "e-stop: not commanding until it is released",
        }
        if status is Status.LAW_FAULT and before is not Status.LAW_FAULT and self.controller.law_fault is not None:
            self.report_law_fault(first_tick_s)
            return
        if status is Status.LAW_STOPPED:
            self.log.warning(
                "the arm is at rest after the control law's failure: no more commands, torque off, "
                f"the brakes hold (category 1); pid_controller ends (exit code {LAW_STOPPED_EXIT_CODE})"
            )
            return
        if status in (Status.REACQUIRING, Status.OK) and before in (None, Status.HOLDING):
            self.log.info("first reading and reference: leading the arm from where it is onto the trajectory")
            return
        if status in warnings:
            self.faults_seen = True
            self.log.warning(warnings[status])
        elif status is Status.REACQUIRING:
            self.faults_seen = True
            self.log.info("fault cleared: re-acquiring from the measurement, blending back onto the trajectory")
        elif status is Status.OK and before not in (None, Status.HOLDING, Status.OK):
            self.log.info("tracking the trajectory again" if self.faults_seen else "on the trajectory: tracking it")

    def report_law_fault(self, first_tick_s: float) -> None:
        """Once, when the law first fails: one error line (what it did, what happens next), the law's traceback
        after it; the line kept as ``law_fault_line`` for the host to leave where the launcher reads it."""
        fault = self.controller.law_fault
        if not self.world_waits and fault.time_s is not None:  # the wall clock's: count from the first tick
            fault = dataclasses.replace(fault, time_s=fault.time_s - first_tick_s)
        line = (
            f"{fault.line()}: controlled stop on the built-in {self.controller.config.stop_law}, "
            "then torque off and the brakes"
        )
        self.log.error(line)
        if fault.traceback:
            self.log.info("the control law's traceback:\n" + fault.traceback.rstrip())
        self.law_fault_line = line

    def say_saturation(self, out: ControlOutput) -> None:
        """One warning per joint, the first time its command stays cut by its limit for over
        ``SATURATION_SAID_AFTER_S``: the law asks for more than the actuator gives."""
        for j in self.saturation.newly_long(out.time_s, out.terms.saturated):
            limit = float(np.broadcast_to(self.controller.config.pid.output_limit, (self.joint_count,))[j])
            unit = EFFORT_UNITS[self.joint_units[j]]  # N·m, or N on a prismatic joint
            effort = "torque" if unit == "N·m" else "force"
            cut = f"its {effort} limit" if abs(abs(out.terms.command[j]) - limit) < 1e-9 else "its slew-rate limit"
            self.log.warning(
                f"{self.joint_names[j]}: the command has been cut by {cut} (±{limit:g} {unit}) for "
                f"{SATURATION_SAID_AFTER_S:g} s in a row: the law asks for more {effort} than the joint has "
                "(said once; saturated_ticks_per_joint in metrics.json counts every tick)"
            )

    def state_row(self, out: ControlOutput) -> list[float]:
        """Every term of the tick, as ``state_layout`` lays them out."""
        values = {name: getattr(out if hasattr(out, name) else out.terms, name) for name in state_layout.FIELDS}
        stamp_s = self.controller.measurement_stamp_s
        return state_layout.encode(out.time_s, out.status.value, stamp_s, self.joint_count, values, self.law_terms(out))

    def law_terms(self, out: ControlOutput) -> tuple[np.ndarray, ...]:
        """The law's extra terms in the layout's order (zeros on a tick the law did not run), then the armature the
        inertia adaptation has learnt, if it is on."""
        reported, zeros = out.law_terms or {}, np.zeros(self.joint_count)
        blocks = tuple(reported.get(name, zeros) for name in self.extra_terms)
        return blocks if self.inertia is None else (*blocks, self.inertia.armature)


#: How far (in logging periods) the instant of the line moves from one period to the next: not a simple fraction,
#: so that no short trajectory period is sampled at a few phases only.
PHASE_STEP = 0.13
#: The latest a line comes in its period (a fraction of it): a late tick still says it within its period.
LATEST_PHASE = 0.9
TIME_EPS_S = 1e-9  # ticks land on a period's instant within rounding


def phase_in_period(k: int) -> float:
    """Where in its logging period (0 … ``LATEST_PHASE``) the ``k``-th line is said: ``k * PHASE_STEP`` folded
    back at each end."""
    walked = math.fmod(k * PHASE_STEP, 2.0 * LATEST_PHASE)
    return walked if walked <= LATEST_PHASE else 2.0 * LATEST_PHASE - walked


class LogSchedule:
    """When the tutorial's once-a-period line (:func:`log_line`) is said: once in each logging period, as the
    tutorial's is, but not at the same instant of each: a trajectory whose period divides the logging period (the
    0.5 Hz sine against a line a second) would be seen at one phase only (in sim time, its zero crossing every time: the
    arm looks dead). The instant moves ``PHASE_STEP`` of a period later each period, and back once it nears the
    period's end, so lines are never closer than ``1 - PHASE_STEP`` periods apart and a periodic motion is seen across
    its range. The first is at the first tick.

    :param period_s: the logging period (``log_period_s``), s
    """

    def __init__(self, period_s: float) -> None:
        self.period_s = period_s
        self.start_s: float | None = None  # when period 0 began (the first tick, or a restart)
        self.index = 0  # the period whose line is due next

    def due(self, now_s: float, period_s: float | None = None) -> bool:
        """Whether the line is said at this tick (``now_s``, s); ``period_s``: the period in force now (a changed
        one starts afresh from the last line said)."""
        if period_s is not None and period_s != self.period_s:
            if self.start_s is not None:
                self.start_s = self.said_at_s()
                self.index = 1
            self.period_s = period_s
        if self.start_s is None:
            self.start_s = now_s
        if now_s < self.instant_s(self.index) - TIME_EPS_S:
            return False
        if self.instant_s(self.index + 1) <= now_s + TIME_EPS_S:
            # A gap in the ticks (a frozen host) spans more than one line's instant: one line, now, and the
            # periods start afresh from it.
            self.start_s, self.index = now_s, 0
        self.index += 1
        return True

    def instant_s(self, k: int) -> float:
        return self.start_s + (k + phase_in_period(k)) * self.period_s

    def said_at_s(self) -> float:
        """When the last line was due (the first period's start before any)."""
        return self.instant_s(self.index - 1) if self.index > 0 else self.start_s


Values = Iterable[float]


def log_line(reference: Values, measured: Values, error: Values, command: Values) -> str:
    """``target=…, actual=…, error=…, torque=…`` (``actual``: the controller's estimate), three decimals, a value per
    joint separated by commas."""
    return f"target={_fmt(reference)}, actual={_fmt(measured)}, error={_fmt(error)}, torque={_fmt(command)}"


def _fmt(values: Values) -> str:
    return ",".join(f"{v:.3f}" for v in values)
