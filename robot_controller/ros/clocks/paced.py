"""The paced world (sim time with ``real_time_factor`` > 0; the default ``run``): sim-time ticks (``stepped``)
on a world clock that keeps pace with the wall clock and pauses with the host, as Gazebo's real-time factor does.

Tick k's effort acts over the period after it, as in sim time, so a run is that run to the bit however busy the
host: the world steps at the period's deadline on the monotonic clock, or when the effort arrives, waiting for it up
to ``drive_timeout_s`` of this process's own running time. An effort later than a period past its deadline is the
loop's miss (``late_efforts``), unless the host took that much time from the loop meanwhile (``late_efforts_host``,
``ros/loop_processes``); none within the drive timeout brakes the arm (category 0), and the world goes on without
waiting while the brakes hold. An effort computed for a tick more than a period before the world's is stale:
dropped, never applied nor releasing the brakes (``stale_efforts``); it shows the loop alive, so the next tick waits
for its effort again. Time this process did not run (a wake-up or a wait more than a period late) is a freeze of the
host, or of the simulator alone, and counts against nobody; the rest of a wait counts against the loop."""

from __future__ import annotations

import threading
import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from robot_controller.blocks import spec
from robot_controller.blocks.block import Log
from robot_controller.blocks.world import World
from robot_controller.parameters.schema import LOCKSTEP_END_MARGIN_S
from robot_controller.ros.clocks.host import FreezeLog, Outlets, Pacing, take
from robot_controller.ros.clocks.stepped import SteppedClock
from robot_controller.ros.loop_processes import LoopProcesses, Sample, host_kept_waiting, process_run_wait_s
from robot_controller.ros.publishing import run_folder

#: An effort this long (control periods) past its tick's deadline is the loop's miss: the world waited for it.
LATE_PERIODS = 1.0
#: An effort for a tick more than this many control periods before the world's is stale: dropped. The world waits
#: for each tick's effort, so only one held up past the drive timeout's brakes is that old. Applied, it would release
#: them with a torque computed on a reading that knew nothing of them (measured: 10 N·m, 0.17 s late).
STALE_PERIODS = 1.0


class PacedClock:
    """Sim-time ticks advanced by a pacing thread at each deadline of the world's clock."""

    physics_running = True

    def __init__(self, world: World, params: Mapping[str, Any], out: Outlets, log: Log, *, recorded: bool) -> None:
        self.world, self.out, self.log = world, out, log
        self.ticks = SteppedClock(world, params, out, log, recorded=recorded)
        self.ticks.resume_for_recorder = False  # this thread resumes a held tick, under the lock
        self.lock = self.ticks.lock
        rate_hz = params["control_rate_hz"]
        self.drive_timeout_s = params["drive_timeout_s"]
        self.period_ns = round(1e9 / (rate_hz * params["real_time_factor"]))  # wall ns per tick
        self.timeout_ns = round(self.drive_timeout_s * 1e9)
        self.late_ns = round(LATE_PERIODS * self.period_ns)
        self.effort_in = False  #: an effort arrived since the last tick
        self.late_efforts = 0  #: ticks the world waited for their effort, or went without it: the loop's own misses
        self.freezes = FreezeLog()
        self.late_for_host = 0  #: late efforts the host made late (the loop waited that long for a CPU): not counted
        self.after_estop = False  #: an e-stop held the brakes, and no effort has come since
        self.stale_ns = round(STALE_PERIODS * 1e9 / rate_hz)  #: world ns
        self.stale_efforts = 0  #: efforts dropped: computed for a tick more than ``stale_ns`` before the world's
        self.loop_heard = False  #: a stale effort came while the drive timeout's brakes hold: wait for the next
        self.loop = LoopProcesses(run_folder())
        self.wait_usage: Sample | None = None  #: the loop's usage when the world began to wait for a tick's effort
        self.effort_arrived = threading.Condition(self.lock)
        self.pacing = Pacing(log)

    def describe(self, params: Mapping[str, Any]) -> str:
        return f"{self.ticks.describe(params)}, paced at {params['real_time_factor']:g}× the wall clock"

    def start(self) -> None:
        self.pacing.start(self.pace, "paced world")

    def try_start(self) -> bool:
        return self.ticks.try_start()

    def recorder_at(self, clock_ns: int) -> None:
        self.ticks.recorder_at(clock_ns)

    def catch_up(self) -> None:
        """No time passes between ticks."""

    def take_effort(self, effort: np.ndarray, tick_ns: int | None = None) -> None:
        """The latest effort is in force from the next step (after the drive timeout too: it releases the brakes),
        unless computed for a tick (``tick_ns``, world ns) that is stale."""
        with self.lock:
            world_ns = self.world.time_ns
            if tick_ns is not None and world_ns - tick_ns > self.stale_ns:
                # The loop is alive, only slow: the next tick waits for its effort again (moving on without
                # waiting, the world would leave a loop slower than a period braked for good).
                self.loop_heard = True
                if not self.past_the_run():  # in the margin after the run the nodes may stop: say nothing
                    self.stale_efforts += 1
                    self.log.warn(
                        "stale_effort",
                        f"{spec.EFFORT.topic} for t = {tick_ns * 1e-9:.2f} s dropped at t = {world_ns * 1e-9:.2f} s: "
                        "computed before the world moved on (a stale effort is no effort)",
                    )
                return
            self.ticks.accept(effort)
            self.effort_in = True
            self.effort_arrived.notify()

    def pace(self) -> None:
        deadline_ns = time.monotonic_ns() + self.period_ns
        while not self.pacing.stopping.is_set():
            remaining_ns, run_wait_s = deadline_ns - time.monotonic_ns(), process_run_wait_s()
            if remaining_ns > 0:
                time.sleep(remaining_ns * 1e-9)
            with self.effort_arrived:
                woken_ns = time.monotonic_ns()
                host_froze = False
                if woken_ns - deadline_ns > self.period_ns:
                    self.freezes.note(woken_ns - deadline_ns)  # the world paused with this process
                    host_froze = self.host_froze(woken_ns - deadline_ns, run_wait_s)
                waited_ns = self.wait_for_effort(woken_ns, host_froze)
                deadline_ns = self.tick(deadline_ns, time.monotonic_ns(), waited_ns)

    def host_froze(self, gap_ns: int, run_wait_s: float) -> bool:
        """Whether this thread's gap of ``gap_ns`` may be a freeze of the whole host (everything stopped together,
        or the hypervisor's pause): this process was not kept waiting for a CPU for half of it since its run-queue
        wait was ``run_wait_s``, as a busy host keeps it, and no process of the loop is still stopped."""
        return (process_run_wait_s() - run_wait_s) * 1e9 < gap_ns / 2 and not self.loop.any_stopped()

    def wait_for_effort(self, since_ns: int, host_froze: bool = False) -> int:
        """Wait (lock held) for the tick's effort, up to the drive timeout of this process's own running time (none
        before the first effort, nor while the brakes hold for its absence unless a stale effort showed the loop
        alive); the time waited, ns. A gap of this process (woken over two periods late) is not counted. A freeze
        of the whole host (``host_froze``) that began before the effort was late adds a drive timeout: the loop's
        messages may then wait for DDS's repair (its 50 ms heartbeat). While a process of the loop is stopped,
        neither: all of the wait is counted, up to one drive timeout."""
        ticks = self.ticks
        braked_for_absence = self.world.braked_for("drive_timeout") and not self.loop_heard
        if not ticks.efforts_applied or ticks.ended or braked_for_absence:
            return 0
        budget_ns = self.timeout_ns * (2 if host_froze else 1)
        if not self.effort_in:
            self.wait_usage = self.loop.usage()
        waited_ns, last_ns = 0, since_ns
        while not self.effort_in and waited_ns < budget_ns and not self.pacing.stopping.is_set():
            run_wait_s, slice_ns = process_run_wait_s(), min(self.period_ns, budget_ns - waited_ns)
            self.effort_arrived.wait(slice_ns * 1e-9)
            now_ns = time.monotonic_ns()
            gap_ns, last_ns = now_ns - last_ns, now_ns
            if self.loop.any_stopped():
                # A process of the loop is stopped (SIGSTOP, a debugger): all of the wait is its stall. No drive
                # timeout is added for a freeze judged the host's just before, and this thread's own gap is not
                # excused: its messages to the stopped reader are what may hold it up (seen: 28 ms).
                budget_ns = self.timeout_ns
            elif gap_ns > 2 * self.period_ns:
                self.freezes.note(gap_ns)  # frozen while it waited: the simulator's time, not the loop's
                if budget_ns == self.timeout_ns and waited_ns <= self.late_ns and self.host_froze(gap_ns, run_wait_s):
                    budget_ns += self.timeout_ns
                gap_ns = slice_ns  # the loop's time all the same: only what ran over it is the simulator's
            waited_ns += gap_ns
        return waited_ns

    def tick(self, deadline_ns: int, now_ns: int, waited_ns: int) -> int:
        """The tick due at ``deadline_ns``, at ``now_ns`` after waiting ``waited_ns`` for its effort (lock held); the
        next deadline (on the grid, or now if the world waited past it)."""
        ticks = self.ticks
        if ticks.ended or not ticks.published or ticks.efforts_applied == 0:
            return now_ns + self.period_ns  # not started, or ended: the world waits for its first effort
        if ticks.held_for_recorder:
            if ticks.recorder_behind():
                return deadline_ns + self.period_ns
            ticks.held_for_recorder = False
            ticks.publish()
            return deadline_ns + self.period_ns
        # In the margin after the run the nodes may stop: brake, say nothing. An e-stop is asked for: the efforts it
        # holds back (until the first after its release) are not the loop's to miss.
        estop = self.world.estopped
        self.after_estop = (self.after_estop or estop) and not self.effort_in
        counted = not self.past_the_run() and not (estop or self.after_estop)
        self.loop_heard = False  # waited for once: if nothing fresh came, the world goes on without waiting again
        if not self.effort_in:
            self.late_efforts += counted
            if not self.world.braked_for("drive_timeout"):
                self.out.write(self.world.set_brake("drive_timeout", True))
                if counted:
                    self.log.warn(
                        "drive_timeout",
                        f"no effort for {self.drive_timeout_s:g} s (t = {self.world.time_s:.2f} s): torque off, "
                        "brakes on (category 0)",
                    )
        elif waited_ns > self.late_ns:
            if self.host_made_it_late(waited_ns):
                self.late_for_host += counted
            else:
                self.late_efforts += counted
        self.effort_in = False
        ticks.waiting_for_effort = True
        ticks.advance()
        return max(deadline_ns + self.period_ns, now_ns)

    def host_made_it_late(self, waited_ns: int) -> bool:
        if self.wait_usage is None or (now := self.loop.usage()) is None:
            return False  # nothing measured: the loop's own
        return host_kept_waiting(now - self.wait_usage, waited_ns - self.late_ns)

    def past_the_run(self) -> bool:
        """In the margin after the run's duration, where the launcher may stop the nodes."""
        end_ns = self.ticks.end_ns
        margin_ns = round(LOCKSTEP_END_MARGIN_S * 1e9)
        return end_ns is not None and self.world.time_ns > end_ns - margin_ns

    def take(self, port: str, value: Any) -> None:
        take(self, port, value)

    def finish(self) -> None:
        """End the thread; say and leave the world's figures."""
        if not self.pacing.stop():
            return
        self.freezes.say_and_leave(
            self.log,
            "the world paused with it",
            late_efforts=self.late_efforts,
            late_efforts_host=self.late_for_host,
            stale_efforts=self.stale_efforts,
        )
        self.ticks.finish()
