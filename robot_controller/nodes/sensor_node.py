"""sensor_node: the encoder. Samples the latest true state from
``/sim/joint_states`` at ``rate_hz``, adds seeded noise, publishes
``/joint_states``. The stamp is that of the true state it measured."""
from __future__ import annotations

import numpy as np
from sensor_msgs.msg import JointState

from robot_controller import config as cfg
from robot_controller.core.sensor_model import measure
from robot_controller.core.validation import check_joint_state
from robot_controller.nodes.base import CONTROL_QOS, StackNode, run


class SensorNode(StackNode):
    def __init__(self) -> None:
        super().__init__("sensor_node")
        seed = self.params["seed"]
        self.rng = np.random.default_rng(None if seed < 0 else seed)
        self.sensor = cfg.sensor_config(self.params)
        self.latest: JointState | None = None
        self.joint_names: list[str] | None = None
        self.pub = self.create_publisher(JointState, "/joint_states", CONTROL_QOS)
        self.create_subscription(JointState, "/sim/joint_states", self.true_state_callback, CONTROL_QOS)
        self.timer = self.create_timer(1.0 / self.params["rate_hz"], self.sample_callback)
        self.out = JointState()
        self.get_logger().info(
            f"sensor at {self.params['rate_hz']:g} Hz: σ position {self.sensor.position_noise_std:g} rad, "
            f"σ velocity {self.sensor.velocity_noise_std:g} rad/s, seed {seed}")

    def check_params(self, params: dict) -> None:
        cfg.sensor_config(params)

    def apply_params(self, params: dict, changed: set[str]) -> None:
        self.sensor = cfg.sensor_config(params)
        if "rate_hz" in changed:
            self.destroy_timer(self.timer)
            self.timer = self.create_timer(1.0 / params["rate_hz"], self.sample_callback)

    def true_state_callback(self, msg: JointState) -> None:
        if self.joint_names is None:
            self.joint_names = list(msg.name)
        self.latest = msg

    def sample_callback(self) -> None:
        msg = self.latest
        if msg is None:
            return
        checked = check_joint_state(msg.name, msg.position, msg.velocity, self.joint_names)
        if isinstance(checked, str):
            self.warn_throttled("true_state", f"/sim/joint_states unusable: {checked}")
            return
        position, velocity = measure(self.sensor, checked[0], checked[1], self.rng)
        out = self.out
        out.header.stamp = msg.header.stamp
        out.name = self.joint_names
        out.position = position.tolist()
        out.velocity = velocity.tolist()
        self.pub.publish(out)


def main(args: list[str] | None = None) -> int:
    return run(SensorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
