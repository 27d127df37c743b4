"""The simulator's paced world (``real_time_factor`` > 0; the default ``run``): lockstep ticks on a world clock
that keeps pace with the wall clock and pauses with the host, as Gazebo's real-time factor does.

Tick k's effort acts over the period after it, as in lockstep: the world steps at that period's deadline on
the monotonic clock, or as soon after it as the effort arrives, within ``GRACE_PERIODS``; while every effort is
in time a run is the lockstep run to the bit. An effort not in by then is the loop's miss: the world goes on
with the effort in force and brakes (category 0) after ``drive_timeout_s`` of world time without one. A
wake-up later than a whole period is a freeze of the host (or of the simulator alone): the world paused with
it, so nothing counts against the loop, which gets a whole period from the wake-up to answer."""

from __future__ import annotations

import json
import math
import threading
import time
from pathlib import Path

import numpy as np

from robot_controller.nodes.simulator.lockstep import LockstepTicks
from robot_controller.parameters.schema.simulator import LOCKSTEP_END_MARGIN_S
from robot_controller.ros import scheduling
from robot_controller.ros.process import WORLD_CLOCK_FILE
from robot_controller.ros.stack_node import StackNode

#: How long past its deadline (control periods) the world waits for a tick's effort before going on without it.
GRACE_PERIODS = 1.0


class FreezeLog:
    """Wall-clock gaps the world paused for: how many, the longest and the total, ms."""

    def __init__(self) -> None:
        self.count = 0
        self.max_ms = 0.0
        self.total_ms = 0.0

    def note(self, gap_ns: int) -> None:
        self.count += 1
        self.max_ms = max(self.max_ms, gap_ns * 1e-6)
        self.total_ms += gap_ns * 1e-6

    def figures(self) -> dict[str, float]:
        return {
            "host_freezes": self.count,
            "host_freeze_ms_max": round(self.max_ms, 3),
            "host_freeze_ms_total": round(self.total_ms, 3),
        }

    def say_and_leave(self, node: StackNode, counts_dir: str, meaning: str, **more: int) -> None:
        """Say the freezes (and ``more`` figures) in one line, and leave them in ``counts_dir`` for metrics.json."""
        figures = {**self.figures(), **more}
        if self.count or any(more.values()):
            said = ", ".join(f"{value} {name.replace('_', ' ')}" for name, value in more.items())
            node.get_logger().info(
                f"the host froze this simulator {self.count} time(s) (longest {self.max_ms:.0f} ms, "
                f"{self.total_ms:.0f} ms in all): {meaning}" + (f"; {said}" if said else "")
            )
        if counts_dir:
            (Path(counts_dir) / WORLD_CLOCK_FILE).write_text(json.dumps(figures))


class PacedTicks:
    """Lockstep ticks advanced by a pacing thread at each deadline of the world's clock."""

    def __init__(self, node: StackNode) -> None:
        self.node = node
        self.ticks = LockstepTicks(node)
        self.ticks.resume_for_recorder = False  # this thread resumes a held tick, under the lock
        rate_hz = node.params["control_rate_hz"]
        self.period_ns = round(1e9 / (rate_hz * node.params["real_time_factor"]))  # wall ns per tick
        self.timeout_ticks = max(1, math.ceil(node.params["drive_timeout_s"] * rate_hz - 1e-9))
        self.effort_in = False  #: an effort arrived since the last tick
        self.ticks_without_effort = 0
        self.late_efforts = 0  #: ticks whose effort missed the deadline: the loop's own misses
        self.freezes = FreezeLog()
        self.grace_ns = round(GRACE_PERIODS * self.period_ns)
        self.effort_arrived = threading.Condition(node.lock)
        self.stopping = threading.Event()
        rt_priority = scheduling.realtime_thread_requested()
        if rt_priority is not None:
            scheduling.install_rt_budget()  # its SIGXCPU handler: from the main thread only
        self.thread = threading.Thread(target=self.pace, args=(rt_priority,), name="paced world", daemon=True)
        self.thread.start()

    def take_effort(self, effort: np.ndarray) -> None:
        """The latest effort is the one in force at the next deadline (a late one too: it is all there is)."""
        with self.node.lock:
            self.ticks.accept(effort)
            self.effort_in = True
            self.ticks_without_effort = 0
            self.effort_arrived.notify()

    def pace(self, rt_priority: int | None) -> None:
        if rt_priority is not None:
            self.node.get_logger().info(scheduling.make_current_thread_realtime(rt_priority))
        deadline_ns = time.monotonic_ns() + self.period_ns
        while not self.stopping.is_set():
            remaining_ns = deadline_ns - time.monotonic_ns()
            if remaining_ns > 0:
                time.sleep(remaining_ns * 1e-9)
            with self.effort_arrived:
                woken_ns = time.monotonic_ns()
                wait_ns = deadline_ns + self.grace_ns - woken_ns
                if not self.effort_in and wait_ns > 0:
                    self.effort_arrived.wait(wait_ns * 1e-9)
                now_ns = time.monotonic_ns()
                # Frozen before the wake-up, or within the wait for the effort (past its grace).
                late_ns = max(woken_ns - deadline_ns, now_ns - woken_ns - max(wait_ns, 0))
                deadline_ns = self.tick(deadline_ns, now_ns, late_ns)

    def tick(self, deadline_ns: int, now_ns: int, late_ns: int) -> int:
        """What is due at ``deadline_ns``, done at ``now_ns``, this process ``late_ns`` late (lock held); the next
        deadline."""
        ticks = self.ticks
        if ticks.ended or not ticks.published or ticks.efforts_applied == 0:
            return now_ns + self.period_ns  # not started, or ended: the world waits for its first effort
        if late_ns > self.period_ns:
            self.freezes.note(late_ns)  # the world paused with this process
            return now_ns + self.period_ns
        if ticks.held_for_recorder:
            if ticks.recorder_behind():
                return deadline_ns + self.period_ns
            ticks.held_for_recorder = False
            ticks.publish()
            return deadline_ns + self.period_ns
        if not self.effort_in and not self.past_the_run():
            self.late_efforts += 1
            self.ticks_without_effort += 1
            brakes = self.node.brakes
            if self.ticks_without_effort >= self.timeout_ticks and "drive_timeout" not in brakes.reasons:
                brakes.set("drive_timeout", True)
                self.node.warn_throttled(
                    "drive_timeout",
                    f"no effort for {self.ticks_without_effort} ticks of world time (t = "
                    f"{self.node.steps_done * self.node.plant.physics_dt:.2f} s): torque off, brakes on (category 0)",
                )
        self.effort_in = False
        ticks.waiting_for_effort = True
        ticks.advance()
        return deadline_ns + self.period_ns

    def past_the_run(self) -> bool:
        """In the margin after the run's duration, where the launcher may stop the nodes (lock held)."""
        end_ns = self.ticks.end_ns
        margin_ns = round(LOCKSTEP_END_MARGIN_S * 1e9)
        return end_ns is not None and self.node.steps_done * self.node.physics_dt_ns > end_ns - margin_ns

    def stop(self, counts_dir: str) -> None:
        """End the thread; say and leave (in ``counts_dir``, if any) the world's figures."""
        if self.stopping.is_set():
            return
        self.stopping.set()
        if self.thread.is_alive():
            self.thread.join(timeout=1.0)
        self.freezes.say_and_leave(self.node, counts_dir, "the world paused with it", late_efforts=self.late_efforts)

    def report(self) -> None:
        self.ticks.report()
