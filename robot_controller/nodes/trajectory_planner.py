"""trajectory_planner: publishes the reference on ``/trajectory`` as
``[positions..., velocities..., accelerations...]`` at ``publish_rate_hz``.
Time starts when the first subscriber is matched (so the controller sees
the trajectory from its beginning); shape changes apply live."""
from __future__ import annotations

from typing import Any

import numpy as np
from std_msgs.msg import Float64MultiArray

from robot_controller import config as cfg
from robot_controller.core.trajectory import make_trajectory
from robot_controller.nodes.base import CONTROL_QOS, StackNode, run


class TrajectoryPlanner(StackNode):
    def __init__(self) -> None:
        super().__init__("trajectory_planner")
        self.trajectory = self._make(self.params)
        self.pub = self.create_publisher(Float64MultiArray, "/trajectory", CONTROL_QOS)
        self.start_s: float | None = None
        self.timer = self.create_timer(1.0 / self.params["publish_rate_hz"], self.publish_callback)
        self.msg = Float64MultiArray()
        p = self.params
        self.get_logger().info(f"trajectory: {p['mode']}, amplitude {p['amplitude']} rad, "
                               f"{p['frequency_hz']:g} Hz, published at {p['publish_rate_hz']:g} Hz")

    @staticmethod
    def _make(params: dict[str, Any]):
        return make_trajectory(params["mode"], **cfg.trajectory_kwargs(params))

    def check_params(self, params: dict[str, Any]) -> None:
        self._make(params)

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        self.trajectory = self._make(params)
        if "publish_rate_hz" in changed:
            self.destroy_timer(self.timer)
            self.timer = self.create_timer(1.0 / params["publish_rate_hz"], self.publish_callback)

    def publish_callback(self) -> None:
        now_s = self.now_s()
        if self.start_s is None:
            if self.pub.get_subscription_count() == 0:
                return  # nobody listens yet: t = 0 is when the controller can hear it
            self.start_s = now_s
        position, velocity, acceleration = self.trajectory.sample(now_s - self.start_s)
        self.msg.data = np.concatenate((position, velocity, acceleration)).tolist()
        self.pub.publish(self.msg)


def main(args: list[str] | None = None) -> int:
    return run(TrajectoryPlanner, args)


if __name__ == "__main__":
    raise SystemExit(main())
