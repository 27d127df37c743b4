"""When the planner block is stepped, chosen once when its node starts (``ros.ticks``):

- :class:`PlannerTimer`, the wall clock: a timer at ``publish_rate_hz``;
- :class:`PlannerGrid`, where the world waits for each command: the world's ticks (port ``clock``) on the grid of the
  planner's period from its start, each grid point's sample one tick early: the controller holds it until its time,
  and its tick never waits for this process (the world's step is the tick).

Time 0 is when the reference's audience (the controller, and the recorder) can hear it (``ready``). Each step's
outputs go to ``publish``; the action server's watch (``monitor``) follows each step."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rosgraph_msgs.msg import Clock as ClockMsg

from robot_controller.blocks import spec
from robot_controller.blocks.planner import Planner
from robot_controller.ros.messages import clock_s, stamp_to_s
from robot_controller.ros.qos import CONTROL_QOS

Publish = Callable[[Mapping[str, Any]], None]
Monitor = Callable[[float], Any]  #: the action server's watch, after each step at its time
_GRID_EPS_S = 1e-6
START_POLL_S = 0.05  #: sim time: how often it looks (on the wall clock) whether it may start, before the world's clock


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
