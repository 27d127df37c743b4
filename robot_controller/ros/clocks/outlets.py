"""What a clock of the world is given by its host (the simulator node): where the world's values go, and the few
facts of the graph it asks about. Plain callables: the clock never reads its host's fields."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from robot_controller.blocks.world import Written


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
