"""The drive process of a run on a robot: the controller stepped by the robot's clock (a tick per state it sends), in
the process that holds the robot's connection, with no ROS in it. What it needs from the graph (the planner's
samples, an e-stop, the end) and what it leaves for it (each tick's record) pass through a
:class:`~robot_controller.hardware.robot_link.RobotLink`, which it never waits on.

Its motion: the planner's samples as they come (the planner holds the arm where it stands, then blends its motion
in: ``start_position``), the controller leading the arm onto them (within ``reacquire_acceleration``). An e-stop or
the run's end brings the reference to rest from where it is, smoothly (no torque step) within ``stop_deceleration``
(category 2, the arm tracking it under torque); then the run's end lets the robot go holding, an e-stop calls
libfranka's ``stop`` (the robot's brakes) and the drive goes on reading where the arm stands until the end. A reflex
or a lost link ends it at once: the robot has stopped itself. A joint the guard brakes for ``GUARD_TICKS`` running
ends the motion with every joint damped to rest."""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from robot_controller.blocks.controller_reports import Reports
from robot_controller.blocks.wiring import BRAKING_STATUSES
from robot_controller.core.controller import Status
from robot_controller.core.controller.safe_motion import SmoothStop
from robot_controller.core.errors import ConfigError
from robot_controller.hardware.franka_arm import RobotFault
from robot_controller.hardware.robot_link import END, ESTOP, GO, RobotLink
from robot_controller.hardware.robot_loop import Robot, RobotLoop, loop_thread, without_frames
from robot_controller.hardware.robot_timing import SUCCESS_WINDOW

#: rad/s: below this on every joint, with the stop's reference at rest, the arm is at rest
REST_RAD_S = 0.02
#: ticks in a row at rest before the motion ends (the arm settled, not passing through zero)
REST_TICKS = 50
#: s a stop may take at most before the motion ends regardless (a joint that cannot settle)
STOP_LIMIT_S = 5.0
#: the robot's success rate (its last 100 commands) below which the motion is stopped under control: the link or this
#: host cannot hold its 1 kHz, and the robot's own stop (20 late in a row) would come without a controlled stop first.
#: (A good 60 s run's low was 0.76: scattered late commands cost nothing.)
SUCCESS_RATE_FLOOR = 0.5
#: ticks in a row the guard may brake a joint before the motion is stopped: its reference asks more than the robot
#: allows there, and a controller fighting the brake winds up (released, it swings the joint past its limit)
GUARD_TICKS = 50
#: s between readings of where a stopped robot stands (outside control)
STANDING_PERIOD_S = 0.01


@dataclass
class DriveEnd:
    """How the drive's motion ended: ``"end"`` (the run's end), ``"estop"``, a controller status that stops the
    motion, or a ``fault`` (the robot's own stop)."""

    why: str
    fault: RobotFault | None = None
    at_s: float = 0.0  #: the tick it ended at (the ROS side's clock)


class Drive:
    """The loop of one run on ``robot``: ``loop``'s controller and guard, ``link`` to the graph, ticks stamped on the
    graph's clock (``time.monotonic()`` + ``clock_offset_s``)."""

    def __init__(
        self,
        loop: RobotLoop,
        robot: Robot,
        link: RobotLink,
        reports: Reports,
        clock_offset_s: float,
        stop_deceleration: float,
        parent_alive: Callable[[], bool] = lambda: True,
        new_gains: Callable[[], tuple[Any, int | None] | None] = lambda: None,
    ) -> None:
        """:param new_gains: a checked change of the controller's configuration and its delay margin, if one came
        (it never waits): taken after the tick's command has gone, in force from the next."""
        self.loop, self.robot, self.link, self.reports = loop, robot, link, reports
        self.new_gains = new_gains
        self.clock_offset_s = clock_offset_s
        self.stop_deceleration = stop_deceleration
        self.parent_alive = parent_alive
        self.joint_count = len(loop.joint_names)
        self._last_s = 0.0  # the last tick's time
        self.started_s = 0.0  #: the first tick's time
        self.success_rate_low = 1.0  #: the robot's success rate that stopped the motion, if one did

    def run(self) -> DriveEnd:
        """Torque control until the run's end, an e-stop, a stop of the controller's, or the robot's fault."""
        controller, link, n = self.loop.controller, self.link, self.joint_count
        stop: SmoothStop | None = None
        why, at_rest, t = None, 0, 0.0
        guard = self.loop.guard
        braked_ticks = np.zeros(n, dtype=int)
        damping, damped_since = False, 0.0  # the guard's stop: the controller left out, every joint damped to rest
        stopped = stopped_row(self.reports, n)
        last_reference: np.ndarray | None = None
        reference_velocity = np.zeros(n)
        sample_acceleration = np.zeros(n)  # the planner's last sample's
        ticks = 0
        with loop_thread():
            try:
                reading = self.robot.start()
                link.say_phase("moving")
                started_s = self.started_s = reading.arrived_s + self.clock_offset_s
                while True:
                    arrived = time.perf_counter()
                    t = reading.arrived_s + self.clock_offset_s
                    if stop is not None:
                        q, v, a = stop.at(t)
                        controller.set_reference(t, q, v, a, t)
                    elif (new := link.new_reference()) is not None:
                        sample_s, sample = new
                        sample_acceleration = sample[2 * n :]
                        controller.set_reference(t, sample[:n], sample[n : 2 * n], sample[2 * n :], sample_s)
                    if damping:
                        self.robot.write(self.loop.damp(reading))
                        compute_s = time.perf_counter() - arrived
                        link.record(t, compute_s, reading.success_rate, reading.missed, reading.position,
                                    reading.velocity, reading.torque_nm, stopped(t, reading.position))  # fmt: skip
                        at_rest = at_rest + 1 if float(np.max(np.abs(reading.velocity))) < REST_RAD_S else 0
                        if at_rest >= REST_TICKS or t - damped_since > STOP_LIMIT_S:
                            return self._finish(DriveEnd(why, at_s=damped_since))
                        reading = self.robot.read()
                        continue
                    tick = self.loop.command(t, reading)
                    self.robot.write(tick.sent_nm)
                    braked_ticks = np.where(guard.braking, braked_ticks + 1, 0)
                    if braked_ticks.max() >= GUARD_TICKS:
                        # The reference asks more than the robot allows where the joint is, and a controller fighting
                        # the brake winds up: every joint is damped to rest instead (category 1), the controller
                        # left out.
                        why = f"guard:{self.loop.joint_names[int(np.argmax(braked_ticks))]}"
                        damping, damped_since, at_rest = True, t, 0
                        link.say_phase("stopping")
                    compute_s = time.perf_counter() - arrived
                    out = tick.out
                    # After the command has gone: what the graph records, and the controller's lines.
                    if last_reference is not None:
                        reference_velocity = (out.reference - last_reference) / max(t - self._last_s, 1e-4)
                    last_reference, self._last_s = out.reference, t
                    ticks += 1
                    if stop is None and not damping and (asked := self._asked(reading, ticks)) is not None:
                        # From the next tick: planned after this one's command went (it takes a fraction of a period)
                        why = asked
                        stop = SmoothStop.starting(
                            t, out.reference, reference_velocity, sample_acceleration, self.stop_deceleration
                        )
                        link.say_phase("stopping")
                    state = self.reports.state_row(out)
                    link.record(t, compute_s, reading.success_rate, reading.missed, reading.position,
                                reading.velocity, reading.torque_nm, state)  # fmt: skip
                    if out.status is not self.reports.last_status:
                        self.reports.status_changed(out.status, started_s)
                    if (change := self.new_gains()) is not None:
                        self._take_gains(*change)
                    if out.status in BRAKING_STATUSES:
                        return self._finish(DriveEnd(str(out.status), at_s=t))
                    if stop is not None:
                        still = stop.at_rest(t) and float(np.max(np.abs(reading.velocity))) < REST_RAD_S
                        at_rest = at_rest + 1 if still else 0
                        if at_rest >= REST_TICKS or t - stop.start_s > STOP_LIMIT_S:
                            return self._finish(DriveEnd(why, at_s=t))
                    reading = self.robot.read()
            except RobotFault as exc:
                return DriveEnd("fault", without_frames(exc), at_s=t)

    def _take_gains(self, config: Any, margin: int | None) -> None:
        """A live change of the controller's gains (bumpless: the PID keeps its I term in N·m), said as the simulated
        controller says it; refused by the controller, the law in force stays, said."""
        try:
            self.loop.controller.set_config(config)
        except ConfigError as exc:
            self.reports.log.warning(f"the law in force stays: the change was refused ({exc})")
            return
        self.reports.log_gains(margin, 1.0 / config.control_period_s)

    def _asked(self, reading: Any, ticks: int) -> str | None:
        """Why the motion should stop now, if it should: an e-stop, the run's end, the graph gone, or the robot taking
        too few of our commands in time (its ``control_command_success_rate``, once a window of them has gone)."""
        if self.link.requested(ESTOP):
            return "estop"
        if self.link.requested(END) or not self.parent_alive():
            return "end"
        if ticks > SUCCESS_WINDOW and reading.success_rate < SUCCESS_RATE_FLOOR:
            self.success_rate_low = reading.success_rate
            return "link"
        return None

    def _finish(self, end: DriveEnd) -> DriveEnd:
        """The motion is over with the arm at rest: an e-stop engages the robot's brakes, anything else lets the robot
        go holding where it stands."""
        if end.why == "estop":
            self.robot.stop()
        else:
            self.robot.finish()
        return end

    def stand(self, state_row: Callable[[float, np.ndarray], np.ndarray]) -> None:
        """After an e-stop: where the stopped arm stands, recorded every ``STANDING_PERIOD_S`` (``state_row``: the
        controller's row for a tick that commands nothing) until the run's end."""
        while not self.link.requested(END) and self.parent_alive():
            with contextlib.suppress(RobotFault):
                position = self.robot.position()
                t = time.monotonic() + self.clock_offset_s
                zeros = np.zeros(self.joint_count)
                self.link.record(t, 0.0, 1.0, 0, position, zeros, zeros, state_row(t, position))
            time.sleep(STANDING_PERIOD_S)


def wait_for_go(link: RobotLink, parent_alive: Callable[[], bool], timeout_s: float) -> bool:
    """Wait until the graph is ready for the first tick (its recorder heard), the graph gone or ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not link.requested(GO):
        if not parent_alive() or time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def stopped_row(reports: Reports, joint_count: int) -> Callable[[float, np.ndarray], np.ndarray]:
    """The controller's state row for a tick of a stopped robot at ``position``: status ``stopped``, nothing
    commanded."""
    from robot_controller.core.controller import state_layout

    def row(t_s: float, position: np.ndarray) -> np.ndarray:
        zeros = np.zeros(joint_count)
        values = {name: zeros for name in state_layout.FIELDS}
        values.update(reference=position, measured=position)
        extra = tuple(zeros for _ in reports.extra_terms) + ((zeros,) if reports.inertia is not None else ())
        return np.asarray(state_layout.encode(t_s, Status.STOPPED.value, t_s, joint_count, values, extra))

    return row


def parent_watch() -> Callable[[], bool]:
    """Whether the process that forked this one still lives (its death hands this one to another parent)."""
    parent = os.getppid()
    return lambda: os.getppid() == parent
