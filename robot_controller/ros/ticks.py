"""When a hosted block is stepped: its node's clock (a :class:`TickSource`), chosen once per process from the node's
parameters by :func:`clock_mode` and :func:`tick_source_class`, the one place that reads the clock switches.

The loop's clock modes: the wall clock, the paced world (sim time at real-time pace, the default ``run``) and sim time
as fast as the graph goes (``--sim-time``). In both sim times the world waits for each command (``world_waits``).
The sources: the world's (``ros.clocks``: wall, paced, stepped), the controller's (``ros.controller_ticks``: a timer,
or readings paired with the world's clock), the planner's (``ros.planner_ticks``: a timer, or the world's clock on
the planner's grid) and the sensor's and the drive's (:class:`OnInput`: each input steps the block at once)."""

from __future__ import annotations

import enum
from collections.abc import Callable, Mapping
from typing import Any, Protocol

from rclpy.node import Node

from robot_controller.blocks.block import Block
from robot_controller.blocks.values import labelled_tick_s
from robot_controller.ros.messages import clock_s

Publish = Callable[[Mapping[str, Any]], None]


class ClockMode(enum.Enum):
    WALL = "wall clock"
    PACED = "paced world"
    STEPPED = "sim time"

    @property
    def world_waits(self) -> bool:
        """Each command acts from its tick and the world waits for it (both sim times)."""
        return self is not ClockMode.WALL


def clock_mode(params: Mapping[str, Any]) -> ClockMode:
    """The clock mode a node's parameters say: its ROS parameter ``lockstep`` (the name users' files set, the paced
    world's too) and, for the world, ``real_time_factor`` (0: as fast as the graph goes)."""
    if not params.get("lockstep", False):
        return ClockMode.WALL
    return ClockMode.PACED if params.get("real_time_factor", 0.0) > 0 else ClockMode.STEPPED


class TickSource(Protocol):
    """What a clock gives its hosted block: when the block is stepped and at what time, and what becomes of an input
    that arrives between steps (held for the next step, or stepped on at once)."""

    def start(self) -> None:
        """Begin stepping (a timer, a thread, or a wait for the graph to be ready)."""

    def take(self, port: str, value: Any) -> None:
        """An input on ``port`` arrived."""

    def finish(self) -> None:
        """The end: no more steps; leave what the clock measured."""


class OnInput:
    """The sensor's and the drive's clock: each input steps the block at once, at the time it arrived (where the
    world waits, the tick it says it was computed for: the world's clock message may come after it); a block with a
    wake period is also stepped on a timer on the wall clock (no time passes between ticks where the world waits)."""

    def __init__(self, node: Node, block: Block, publish: Publish, *, world_waits: bool) -> None:
        self.node, self.block, self.publish, self.world_waits = node, block, publish, world_waits

    def start(self) -> None:
        period_s = self.block.wake_period_s()
        if period_s is not None and not self.world_waits:
            self.node.create_timer(period_s, lambda: self.publish(self.block.step(clock_s(self.node), {})))
        self.publish(self.block.start())

    def take(self, port: str, value: Any) -> None:
        tick_s = labelled_tick_s(getattr(value, "label", "")) if self.world_waits else None
        self.publish(self.block.step(clock_s(self.node) if tick_s is None else tick_s, {port: value}))

    def finish(self) -> None:
        finish = getattr(self.block, "finish", None)
        if finish is not None:
            self.publish(finish())


def tick_source_class(node_name: str, mode: ClockMode) -> type:
    """The clock that steps ``node_name``'s block in ``mode``. Imported here, when chosen: a process loads only its
    own clock (the world's brings MuJoCo)."""
    if node_name == "simulator":
        from robot_controller.ros.clocks.paced import PacedClock
        from robot_controller.ros.clocks.stepped import SteppedClock
        from robot_controller.ros.clocks.wall import WallClock

        return {ClockMode.WALL: WallClock, ClockMode.PACED: PacedClock, ClockMode.STEPPED: SteppedClock}[mode]
    if node_name == "pid_controller":
        from robot_controller.ros.controller_ticks import PairedTicks, TimerTicks

        return PairedTicks if mode.world_waits else TimerTicks
    if node_name == "trajectory_planner":
        from robot_controller.ros.planner_ticks import PlannerGrid, PlannerTimer

        return PlannerGrid if mode.world_waits else PlannerTimer
    return OnInput
