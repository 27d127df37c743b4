"""What a clock of the world does with an input that arrives between its steps (``ros.ticks.TickSource.take``): an
effort goes to the clock, which knows when it acts; a brake request, an e-stop or a push is taken under the clock's
lock, the physics up to now first advanced without it. At the end, the clock stops and leaves what it measured."""

from __future__ import annotations

import os
from typing import Any

from robot_controller.blocks.values import labelled_tick_s
from robot_controller.ros.publishing import COUNTS_DIR_ENV


def take(clock: Any, port: str, value: Any) -> None:
    """``value`` on the world's input ``port``, taken by ``clock`` (a wall, paced or stepped clock)."""
    world = clock.world
    if port == "effort":
        effort = world.check_effort(value)
        if effort is not None:
            tick_s = labelled_tick_s(value.label)  # the drive passes the controller's tick on
            clock.take_effort(effort, None if tick_s is None else round(tick_s * 1e9))
    elif port == "brake_request":
        with clock.lock:
            clock.out.write(world.take_brake_request(bool(value)))
    elif port == "estop":
        take_estop(clock, bool(value))
    elif port == "disturbance":
        with clock.lock:
            clock.catch_up()  # the physics up to now ran without it
            world.take_disturbance(value, physics_running=clock.physics_running)


def take_estop(clock: Any, on: bool) -> None:
    with clock.lock:
        if on == clock.world.estopped:
            return  # said again (the button repeats it): nothing changes
        clock.catch_up()  # the physics up to now ran without it
        clock.out.write(clock.world.take_estop(on))
    if not on:
        with clock.lock:  # released, the brakes wait for the drive's next effort
            clock.out.write(clock.world.set_brake("drive_timeout", True))


def finish(clock: Any) -> None:
    """Stop ``clock`` (once) and leave its figures in the run's folder."""
    clock.stop(os.environ.get(COUNTS_DIR_ENV, ""))
