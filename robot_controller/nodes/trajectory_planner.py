"""trajectory_planner: publishes the reference on ``/trajectory``.

Each message is ``[positions…, velocities…, accelerations…, time_s]``, the
layout labelled; ``time_s`` is when the sample was taken, so the controller
evaluates it at its own tick without guessing the transport delay (the
tutorial's controller reads only the first two values and is unaffected).

Time starts when the first consumer is matched, so the controller sees the
trajectory from its beginning. Wall clock: a timer at ``publish_rate_hz``.
Lockstep: a sample whenever ``/clock`` reaches the next ``1/publish_rate_hz``
grid point. Shape changes apply live.
"""
from __future__ import annotations

from typing import Any

import numpy as np
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from robot_controller import parameters as cfg
from robot_controller.core.trajectory import make_trajectory
from robot_controller.ros.process import run
from robot_controller.ros.publishing import GatedPublisher
from robot_controller.ros.qos import CONTROL_QOS
from robot_controller.ros.stack_node import StackNode
from robot_controller.ros.stamps import stamp_to_s

_GRID_EPS_S = 1e-6


class TrajectoryPlanner(StackNode):
    def __init__(self) -> None:
        super().__init__("trajectory_planner")
        p = self.params
        self.trajectory = self._make(p)
        self.pub = GatedPublisher(self, Float64MultiArray, "/trajectory")
        self.start_s: float | None = None
        self.next_sample_s = 0.0
        self.clock_s = 0.0  # lockstep: the latest /clock (time is 0 until the first)
        self.msg = Float64MultiArray()
        n = p["joint_count"]
        self.msg.layout.dim = [MultiArrayDimension(label=name, size=n, stride=n)
                               for name in ("position", "velocity", "acceleration")]
        self.msg.layout.dim.append(MultiArrayDimension(label="time_s", size=1, stride=1))
        self.timer = None
        if p["lockstep"]:
            self.create_subscription(ClockMsg, "/clock", self.clock_callback, CONTROL_QOS)
            # Before the first /clock the time is 0: poll (on the wall clock) for the controller.
            self.start_poll = self.create_timer(0.05, lambda: self.sample_at(self.clock_s),
                                                clock=Clock(clock_type=ClockType.STEADY_TIME))
        else:
            self.timer = self.create_timer(1.0 / p["publish_rate_hz"], lambda: self.sample_at(self.now_s()))
        self.get_logger().info(f"trajectory: {p['mode']}, amplitude {p['amplitude']} rad, "
                               f"{p['frequency_hz']:g} Hz, published at {p['publish_rate_hz']:g} Hz"
                               + (", lockstep" if p["lockstep"] else ""))

    @staticmethod
    def _make(params: dict[str, Any]):
        return make_trajectory(params["mode"], **cfg.trajectory_kwargs(params))

    def check_params(self, params: dict[str, Any]) -> None:
        self._make(params)

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        self.trajectory = self._make(params)
        if "publish_rate_hz" in changed and self.timer is not None:
            self.destroy_timer(self.timer)
            self.timer = self.create_timer(1.0 / params["publish_rate_hz"], lambda: self.sample_at(self.now_s()))

    def clock_callback(self, msg: ClockMsg) -> None:
        self.clock_s = stamp_to_s(msg.clock)
        if self.start_s is not None:
            self.sample_at(self.clock_s)

    def sample_at(self, now_s: float) -> None:
        if self.start_s is None:
            if not self.pub.open:
                return  # t = 0 is when the controller (and the recorder) can hear it
            self.start_s = now_s
            self.next_sample_s = now_s
            if self.params["lockstep"]:
                self.destroy_timer(self.start_poll)
        if self.params["lockstep"]:
            if now_s < self.next_sample_s - _GRID_EPS_S:
                return
            period = 1.0 / self.params["publish_rate_hz"]
            self.next_sample_s = self.start_s + (np.floor((now_s - self.start_s + _GRID_EPS_S) / period) + 1) * period
        position, velocity, acceleration = self.trajectory.sample(now_s - self.start_s)
        self.msg.data = np.concatenate((position, velocity, acceleration, [now_s])).tolist()
        self.pub.publish(self.msg)


def main(args: list[str] | None = None) -> int:
    return run(TrajectoryPlanner, args)


if __name__ == "__main__":
    raise SystemExit(main())
