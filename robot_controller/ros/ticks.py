"""When a hosted block is stepped: its node's clock (a :class:`TickSource`), chosen once per process from the node's
parameters by :func:`clock_mode` and :func:`tick_source_class`, the one place that reads the clock switches.

The loop's clock modes: the wall clock, the paced world (sim time at real-time pace, the default ``run``) and sim time
as fast as the graph goes (``--sim-time``). In both sim times the world waits for each command (``world_waits``).
The sources: the world's (``ros.clocks``: wall, paced, stepped), the controller's (``ros.controller_ticks``: a timer,
or readings paired with the world's clock), the planner's (:class:`PlannerTimer` on the wall clock; where the world
waits, :class:`PlannerGrid`: the world's ticks on the grid of the planner's period from its start, each grid point's
sample one tick early, so the controller holds it until its time and its tick never waits for this process) and the
sensor's and the drive's (:class:`OnInput`: each input steps the block at once). The planner's time 0 is when the
reference's audience (the controller, and the recorder) can hear it (``ready``); the action server's watch
(``monitor``) follows each of its steps."""

from __future__ import annotations

import enum
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rosgraph_msgs.msg import Clock as ClockMsg

from robot_controller.blocks import spec
from robot_controller.blocks.block import Block
from robot_controller.ros.messages import clock_s, stamp_to_s
from robot_controller.ros.qos import CONTROL_QOS

if TYPE_CHECKING:
    from robot_controller.blocks.planner import Planner

Publish = Callable[[Mapping[str, Any]], None]
Monitor = Callable[[float], Any]  #: the action server's watch, after each step at its time
_GRID_EPS_S = 1e-6
START_POLL_S = 0.05  #: sim time: how often it looks (on the wall clock) whether it may start, before the world's clock


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
        tick_s = getattr(value, "tick_s", None) if self.world_waits else None
        self.publish(self.block.step(clock_s(self.node) if tick_s is None else tick_s, {port: value}))

    def finish(self) -> None:
        finish = getattr(self.block, "finish", None)
        if finish is not None:
            self.publish(finish())


class PlannerTimer:
    """The wall clock: a timer at ``publish_rate_hz``, retimed when it changes."""

    def __init__(
        self, node: Node, block: Planner, publish: Publish, *, ready: Callable[[], bool], monitor: Monitor
    ) -> None:
        self.node, self.block, self.publish, self.ready, self.monitor = node, block, publish, ready, monitor
        self.timer: Any = None

    def now_s(self) -> float:
        return clock_s(self.node)

    def start(self) -> None:
        self.publish(self.block.start())
        self.timer = self.node.create_timer(1.0 / self.block.params["publish_rate_hz"], self.tick)

    def retime(self) -> None:
        """The block's ``publish_rate_hz`` changed."""
        self.node.destroy_timer(self.timer)
        self.timer = self.node.create_timer(1.0 / self.block.params["publish_rate_hz"], self.tick)

    def tick(self) -> None:
        now_s = self.now_s()
        if self.block.start_s is None and not self.ready():
            return  # t = 0 is when the controller (and the recorder) can hear it
        self.publish(self.block.step(now_s, {}))
        self.monitor(now_s)

    def take(self, port: str, value: Any) -> None:
        self.block.step(self.now_s(), {port: value})

    def finish(self) -> None:
        pass


class PlannerGrid:
    """Where the world waits: the world's ticks on the planner's grid, each sample a tick early."""

    def __init__(
        self, node: Node, block: Planner, publish: Publish, *, ready: Callable[[], bool], monitor: Monitor
    ) -> None:
        self.node, self.block, self.publish, self.ready, self.monitor = node, block, publish, ready, monitor
        self.clock_s = 0.0  # the world's latest clock (0 until the first)
        self.next_sample_s = 0.0  # the next point of the block's grid
        self.start_poll: Any = None

    def now_s(self) -> float:
        """The planner's time: the world's latest clock."""
        return self.clock_s

    def start(self) -> None:
        self.publish(self.block.start())
        self.node.create_subscription(ClockMsg, spec.CLOCK.topic, self.clock_callback, CONTROL_QOS)
        # Before the world's first clock the time is 0: poll (on the wall clock) for the controller.
        self.start_poll = self.node.create_timer(
            START_POLL_S, lambda: self.on_grid(self.clock_s), clock=Clock(clock_type=ClockType.STEADY_TIME)
        )

    def retime(self) -> None:
        """The grid's next point follows the new period from the next step on."""

    def clock_callback(self, msg: ClockMsg) -> None:
        previous_s, self.clock_s = self.clock_s, stamp_to_s(msg.clock)
        if self.block.start_s is None:
            return
        self.on_grid(self.clock_s)
        # The sample due at the next tick goes out now, a tick early.
        step_s = self.clock_s - previous_s
        if step_s > 0:
            self.on_grid(self.clock_s + step_s)
        self.monitor(self.clock_s)

    def on_grid(self, now_s: float) -> None:
        """Step the block if ``now_s`` is at (or past) the next point of its period's grid."""
        start_s = self.block.start_s
        if start_s is None:
            if not self.ready():
                return  # t = 0 is when the controller (and the recorder) can hear it
            start_s = self.next_sample_s = now_s
            self.node.destroy_timer(self.start_poll)
        if now_s < self.next_sample_s - _GRID_EPS_S:
            return
        period = 1.0 / self.block.params["publish_rate_hz"]
        self.next_sample_s = start_s + (np.floor((now_s - start_s + _GRID_EPS_S) / period) + 1) * period
        self.publish(self.block.step(now_s, {}))

    def take(self, port: str, value: Any) -> None:
        self.block.step(self.now_s(), {port: value})

    def finish(self) -> None:
        pass


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
        return PlannerGrid if mode.world_waits else PlannerTimer
    return OnInput
