"""What a clock of the world exchanges with its host (the simulator node): the outlets the world's values go to and
the few facts of the graph it asks about (plain callables: the clock never reads its host's fields); the inputs that
arrive between its steps; its pacing thread; and the wall-clock gaps it woke up late by (the host's, or its own
process's, freezes), said at the end and left for ``metrics.json``."""

from __future__ import annotations

import json
import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from robot_controller.blocks.block import Log
from robot_controller.blocks.world import Written
from robot_controller.ros import scheduling
from robot_controller.ros.process import WORLD_CLOCK_FILE
from robot_controller.ros.publishing import leave

#: How the world's figures read in its closing line.
SAID = {
    "late_efforts": "late efforts (the loop's own)",
    "late_efforts_host": "late efforts the host made late",
    "stale_efforts": "stale efforts dropped",
}


@dataclass(frozen=True)
class Outlets:
    write: Callable[[Written], None]  #: publish what the world wrote (port, value), in order
    write_state: Callable[[int], None]  #: publish the world's true state (and disturbance applied), stamped ns
    state_open: Callable[[], bool]  #: the true state's audience has matched
    write_clock: Callable[[int], None] = lambda stamp_ns: None  #: publish the sim's clock (sim time), ns
    ready: Callable[[], bool] = lambda: True  #: sim time: the sensor and the drive matched, the clock can start
    ros_now_ns: Callable[[], int] = lambda: 0  #: the host's ROS clock, ns (the wall clock's stamps)
    motor_present: Callable[[], bool] = lambda: False  #: a drive publishes its brake request
    save_position: Callable[[object], None] | None = None  #: keep the arm's position for a respawn


def take(clock: Any, port: str, value: Any) -> None:
    """``value`` on the world's input ``port``, taken by ``clock``: an effort goes to the clock, which knows when it
    acts; a brake request, an e-stop or a push is taken under the clock's lock, the physics up to now first advanced
    without it."""
    world = clock.world
    if port == "effort":
        effort = world.check_effort(value)
        if effort is not None:
            tick_s = value.tick_s  # the drive passes the controller's tick on
            clock.take_effort(effort, None if tick_s is None else round(tick_s * 1e9))
    elif port == "brake_request":
        with clock.lock:
            clock.out.write(world.take_brake_request(bool(value)))
    elif port == "estop":
        take_estop(clock, bool(value))
    elif port == "disturbance":
        with clock.lock:
            clock.catch_up()
            world.take_disturbance(value, physics_running=clock.physics_running)


def take_estop(clock: Any, on: bool) -> None:
    with clock.lock:
        if on == clock.world.estopped:
            return  # said again (the button repeats it): nothing changes
        clock.catch_up()
        clock.out.write(clock.world.take_estop(on))
    if not on:
        with clock.lock:  # released, the brakes wait for the drive's next effort
            clock.out.write(clock.world.set_brake("drive_timeout", True))


class Pacing:
    """A clock's pacing thread, SCHED_FIFO under ``--realtime`` (``ros.scheduling``), stopped once."""

    def __init__(self, log: Log) -> None:
        self.log = log
        self.realtime = False
        self.stopping = threading.Event()
        self.thread: threading.Thread | None = None

    def start(self, pace: Callable[[], None], name: str) -> None:
        priority = scheduling.realtime_thread_requested()
        if priority is not None:
            scheduling.install_rt_budget()  # its SIGXCPU handler: from the main thread only

        def run() -> None:
            if priority is not None:
                self.log.info(scheduling.make_current_thread_realtime(priority))
                self.realtime = True
            pace()

        self.thread = threading.Thread(target=run, name=name, daemon=True)
        self.thread.start()

    def stop(self) -> bool:
        """End the thread; False if it was stopped already."""
        if self.stopping.is_set():
            return False
        self.stopping.set()
        if self.thread is not None and self.thread.is_alive():
            self.thread.join(timeout=1.0)
        return True


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

    def say_and_leave(self, log: Log, meaning: str, **more: int) -> None:
        """Say the freezes (and ``more`` figures) in one line, and leave them in the run's folder for metrics.json."""
        if self.count or any(more.values()):
            said = ", ".join(f"{value} {SAID.get(name, name.replace('_', ' '))}" for name, value in more.items())
            log.info(
                f"the host froze this simulator {self.count} time(s) (longest {self.max_ms:.0f} ms, "
                f"{self.total_ms:.0f} ms in all): {meaning}" + (f"; {said}" if said else "")
            )
        leave(WORLD_CLOCK_FILE, json.dumps({**self.figures(), **more}))
