"""The wall clock (``run --wall-clock``): a pacing thread sleeps to each absolute deadline of a
``publish_rate_hz`` grid (never a drifting timer), steps the physics due by then on the monotonic clock and publishes
the true state. Physics time 0 is the first effort (``wait_for_first_command``, brakes on until then) or the start.
The efforts act from when they arrive; none for ``drive_timeout_s`` brakes the arm (category 0), and the brakes'
state is repeated twice a second, so a late listener learns it."""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from robot_controller.blocks import spec
from robot_controller.blocks.block import Log
from robot_controller.blocks.world import World
from robot_controller.ros import scheduling
from robot_controller.ros.clocks.host import FreezeLog, Outlets, Pacing, take
from robot_controller.ros.process import stop_requested

# Catch up at most this many physics steps in one call; beyond, the sim runs slower than real time.
MAX_CATCH_UP_STEPS = 100
BRAKES_REPORT_PERIOD_NS = 500_000_000
# The simulator's own pause up to this long does not count against the drive's timeout; a longer one brakes.
MAX_EXCUSED_GAP_NS = 1_000_000_000


class WallClock:
    """The pacing thread and the physics it steps on the monotonic clock."""

    def __init__(self, world: World, params: Mapping[str, Any], out: Outlets, log: Log) -> None:
        self.world, self.out, self.log = world, out, log
        self.lock = threading.Lock()  #: the world: the pacing thread vs the executor's callbacks
        # Physics time 0 on the monotonic clock (None before the first command) and the ROS clock.
        self.anchor_mono_ns: int | None = None
        self.anchor_ros_ns = 0
        self.behind_warned = False
        self.freezes = FreezeLog()  # wake-ups later than a whole period: the host's (or this process's) freezes
        self.pacing = Pacing(log)
        self.period_ns = round(1e9 / params["publish_rate_hz"])
        self.wait_for_first_command = params["wait_for_first_command"]
        self.drive_timeout_s = params["drive_timeout_s"]
        self.timeout_ns = round(1e9 * self.drive_timeout_s)
        self.last_effort_mono_ns = 0
        self.next_report_ns = 0
        self.said_brake_wait = False  # the start's wait for the drive's brake request, said once

    def describe(self, params: Mapping[str, Any]) -> str:
        return f"true state at {params['publish_rate_hz']:g} Hz, paced on absolute deadlines" + (
            ", brakes on until the first command" if self.wait_for_first_command else ""
        )

    @property
    def physics_running(self) -> bool:
        return self.anchor_mono_ns is not None

    def start(self) -> None:
        if not self.wait_for_first_command:
            self.begin()
        # A short GIL switch interval: the pacing thread must not wait long for a callback on the executor thread.
        sys.setswitchinterval(0.0005)
        self.pacing.start(self.pace, "pacing")

    def try_start(self) -> bool:
        return True  # nothing waits for the graph: the thread publishes once the audience matched

    def recorder_at(self, clock_ns: int) -> None:
        """The recorder follows the wall clock: nothing to hold."""

    def begin(self) -> None:
        self.anchor_mono_ns = time.monotonic_ns()
        self.anchor_ros_ns = self.out.ros_now_ns()

    def catch_up(self) -> None:
        """Step what is due by now on the old inputs (lock held): what comes next acts from now."""
        if self.physics_running:
            self.advance(time.monotonic_ns())

    def take_effort(self, effort: np.ndarray, tick_ns: int | None = None) -> None:
        """The effort in force from now; the first starts the physics (``wait_for_first_command``)."""
        world = self.world
        with self.lock:
            if world.estopped:
                world.take_effort(effort)  # ignored, and said
                return
            if not world.request_heard and self.out.motor_present():
                # A drive is there: its latched brake request comes before any effort releases the brakes. The
                # two race at the start (a respawned simulator's too): normal, said once.
                if not self.said_brake_wait:
                    self.said_brake_wait = True
                    self.log.info(
                        f"efforts wait for the motor's latched {spec.BRAKE_REQUEST.topic} state (the start's race)"
                    )
                return
            if not self.physics_running:
                self.begin()
                self.log.info("first command received, physics running")
            else:
                self.catch_up()  # the new torque acts from here
            self.last_effort_mono_ns = time.monotonic_ns()
            if world.braked_for("drive_timeout"):
                self.log.info("efforts back: brakes released")
            self.out.write(world.take_effort(effort))

    def pace(self) -> None:
        """The pacing thread: sleep to each absolute deadline, step, publish."""
        world = self.world
        period_ns = self.period_ns
        deadline_ns = time.monotonic_ns() + period_ns
        last_wakeup_ns = time.monotonic_ns()
        while not self.pacing.stopping.is_set():
            remaining_ns = deadline_ns - time.monotonic_ns()
            if remaining_ns > 0:
                time.sleep(remaining_ns * 1e-9)
            with self.lock:
                now_ns = time.monotonic_ns()
                gap_ns = now_ns - last_wakeup_ns
                last_wakeup_ns = now_ns
                if self.physics_running:
                    self.excuse_own_gap(gap_ns)
                    self.check_drive_timeout(now_ns)
                    # Step to the deadline (not to now): the state is that of the grid point.
                    self.advance(max(deadline_ns, self.anchor_mono_ns))
                    stamp_ns = self.anchor_ros_ns + world.time_ns
                else:
                    stamp_ns = self.out.ros_now_ns()  # brakes on: the arm holds still
                if self.out.save_position is not None:
                    self.out.save_position(world.position())
                if self.out.state_open():
                    self.out.write_state(stamp_ns)
                if now_ns >= self.next_report_ns:  # the brakes' state twice a second: a late listener learns it
                    self.next_report_ns = now_ns + BRAKES_REPORT_PERIOD_NS
                    self.out.write(world.brakes_state())
                anchor = self.anchor_mono_ns
            # Next deadline on the grid of physics time 0 (or the last one while braked), skipping those missed.
            base = anchor if anchor is not None else deadline_ns
            if now_ns - deadline_ns >= period_ns:
                self.freezes.note(now_ns - deadline_ns)
            if self.pacing.realtime and scheduling.demoted.is_set():
                self.pacing.realtime = False
                self.log.warn(
                    "demoted", "pacing thread used its real-time CPU budget without sleeping: back to normal scheduling"
                )
            deadline_ns = base + ((max(deadline_ns, now_ns) - base) // period_ns + 1) * period_ns

    def excuse_own_gap(self, gap_ns: int) -> None:
        """A pause of this process between two wake-ups ``gap_ns`` apart (lock held, physics running)."""
        if gap_ns <= 2 * self.period_ns:
            return
        if gap_ns <= MAX_EXCUSED_GAP_NS:
            # Time this process did not run does not count against the drive, whose efforts are waiting.
            self.last_effort_mono_ns += gap_ns - self.period_ns
        elif not self.world.braked_for("drive_timeout"):
            # The efforts waiting are as old as the pause: resume braked until a fresh one arrives.
            self.out.write(self.world.set_brake("drive_timeout", True))
            self.log.warn(
                "own_gap", f"this simulator did not run for {gap_ns * 1e-9:.2f} s: resuming with the brakes on"
            )

    def check_drive_timeout(self, now_ns: int) -> None:
        """Brake when no effort came for ``drive_timeout_s`` (lock held); physics to now on the old torque, then off."""
        if now_ns - self.last_effort_mono_ns > self.timeout_ns and not self.world.braked_for("drive_timeout"):
            self.advance(now_ns)
            self.out.write(self.world.set_brake("drive_timeout", True))
            if stop_requested():  # the run's end (SIGINT to every node): the drive stopped first
                return
            self.log.warn(
                "drive_timeout",
                f"no effort for over {self.drive_timeout_s:g} s: torque off, brakes on (category 0)",
            )

    def advance(self, until_mono_ns: int) -> None:
        world = self.world
        due = (until_mono_ns - self.anchor_mono_ns) // world.physics_dt_ns - world.steps_done
        if due <= 0:
            return
        if due > MAX_CATCH_UP_STEPS:
            if not self.behind_warned:
                self.log.warn("behind", f"physics {due} steps behind the clock: slowing below real time")
                self.behind_warned = True
            shift_ns = (due - MAX_CATCH_UP_STEPS) * world.physics_dt_ns
            self.anchor_mono_ns += shift_ns
            self.anchor_ros_ns += shift_ns
            due = MAX_CATCH_UP_STEPS
        world.advance(int(due))

    def take(self, port: str, value: Any) -> None:
        take(self, port, value)

    def finish(self) -> None:
        """End the thread; say how often the host froze the loop, which on the wall clock counts against it."""
        if self.pacing.stop():
            self.freezes.say_and_leave(self.log, "on the wall clock the late commands and brakes then were the host's")
