"""Sim time as fast as the graph goes (``real_time_factor`` 0; ``run --sim-time``): the clock
publishes the world's true state and the sim's clock for tick k, then waits; the effort for tick k runs exactly one
control period of physics. It holds the next tick while the recorder (its ``recorder_clock``) is
``RECORDER_LAG_MAX_S`` behind, so no queue overflows. The paced world (``paced``) runs these ticks on its own clock."""

from __future__ import annotations

import threading
from collections.abc import Mapping
from typing import Any

import numpy as np

from robot_controller.blocks.block import Log
from robot_controller.blocks.world import World
from robot_controller.core.model import steps_per_period
from robot_controller.ros.clocks.host import Outlets, take

#: Sim seconds the recorder may be behind: under a third of what the queues hold, and over what
#: the loop runs between its reports (0.1 s wall, 1-2 sim s) so a recorder keeping up never holds it.
RECORDER_LAG_MAX_S = 3.0


class SteppedClock:
    """The world's ticks in sim time: one control period of physics per effort."""

    physics_running = True  #: physics runs from tick 0 (its time moves only with the efforts)

    def __init__(self, world: World, params: Mapping[str, Any], out: Outlets, log: Log, *, recorded: bool) -> None:
        self.world, self.out, self.log = world, out, log
        self.lock = threading.Lock()  #: the world: a paced world's thread vs the executor's callbacks
        self.efforts_applied = 0
        self.published = 0
        #: the tick the recorder has taken (None: not recorded); a tick is held while it lags
        self.recorder_clock_ns: int | None = 0 if recorded else None
        self.held_for_recorder = False
        self.holds_for_recorder = 0
        self.resume_for_recorder = True  #: the recorder's report publishes a held tick (a paced world's thread does)
        end_s = params["lockstep_end_s"]
        self.end_ns = round(end_s * 1e9) if end_s > 0 else None  #: no tick after this (the run's end)
        self.ended = False
        self.steps_per_tick = steps_per_period(world.physics_dt, 1.0 / params["control_rate_hz"])
        self.waiting_for_effort = False
        self.finished = False

    def describe(self, params: Mapping[str, Any]) -> str:
        return f"sim time at {params['control_rate_hz']:g} Hz on the clock"

    def start(self) -> None:
        """Nothing to start: tick 0 goes out once the graph is ready (:meth:`try_start`)."""

    def try_start(self) -> bool:
        """Publish tick 0 if the sensor (and recorder) listen and the drive talks (nothing is ever re-sent)."""
        if not self.out.ready():
            return False
        self.log.info("sim time: sensor and motor matched, starting at t = 0")
        with self.lock:
            self.publish()
        return True

    def catch_up(self) -> None:
        """No time passes between ticks."""

    def take_effort(self, effort: np.ndarray, tick_ns: int | None = None) -> None:
        with self.lock:
            if not self.waiting_for_effort:
                self.log.warn("extra_effort", "sim time: effort with no tick waiting for it, ignored")
                return
            self.accept(effort)
            self.advance()

    def accept(self, effort: np.ndarray) -> None:
        self.waiting_for_effort = False
        self.finished = False
        self.out.write(self.world.take_effort(effort))
        self.efforts_applied += 1

    def advance(self) -> None:
        """One control period of physics on the effort in force, then the next tick (unless the run's end or
        the recorder holds it; lock held)."""
        self.world.advance(self.steps_per_tick)
        if self.end_ns is not None and self.world.time_ns > self.end_ns:
            # The run's end: no more ticks, so the graph falls quiet and the recorder catches up.
            if not self.ended:
                self.ended = True
                self.log.info(f"sim time: the run's end, t = {self.end_ns * 1e-9:g} s: no more ticks")
            return
        if self.recorder_behind():
            self.held_for_recorder = True
            self.holds_for_recorder += 1
            return
        self.publish()

    def recorder_behind(self) -> bool:
        lag_ns = self.world.time_ns - (self.recorder_clock_ns or 0)
        return self.recorder_clock_ns is not None and lag_ns > RECORDER_LAG_MAX_S * 1e9

    def recorder_at(self, clock_ns: int) -> None:
        self.recorder_clock_ns = max(self.recorder_clock_ns or 0, clock_ns)
        if self.resume_for_recorder and self.held_for_recorder and not self.recorder_behind():
            with self.lock:
                self.held_for_recorder = False
                self.publish()

    def publish(self) -> None:
        """The true state first: the tick's longest path (sensor → controller → drive → here) starts there."""
        stamp_ns = self.world.time_ns
        self.waiting_for_effort = True
        self.published += 1
        self.out.write_state(stamp_ns)
        self.out.write_clock(stamp_ns)

    def take(self, port: str, value: Any) -> None:
        take(self, port, value)

    def finish(self) -> None:
        """Say what the clock did (once)."""
        if self.finished:
            return
        self.finished = True
        self.log.info(
            f"sim time: {self.published} ticks published, {self.efforts_applied} "
            f"efforts applied, t = {self.world.time_s:.3f} s"
            + (f"; held {self.holds_for_recorder} times for the recorder" if self.holds_for_recorder else "")
        )
