"""motor_node: the actuator. Each ``/joint_commands`` torque is saturated to
``±torque_max`` (and lagged, if set) and passed on as ``/sim/effort`` at once.

It also measures the loop's end-to-end latency where it ends: from the
stamp of the sensor reading a command was computed from (carried on
``/controller/state`` beside the same command) to the moment the command
reached the motor. One value per command on ``/motor/command_latency`` (s).
"""
from __future__ import annotations

from collections import deque

import numpy as np
from std_msgs.msg import Float64MultiArray

from robot_controller import config as cfg
from robot_controller import resources
from robot_controller.core import state_layout
from robot_controller.core.actuator import Actuator
from robot_controller.core.plant import joint_names, load_model
from robot_controller.core.validation import check_effort
from robot_controller.nodes.base import CONTROL_QOS, StackNode, run


class MotorNode(StackNode):
    def __init__(self) -> None:
        super().__init__("motor_node")
        self.joint_names = joint_names(load_model(resources.resolve_urdf(self.params["urdf_path"])))
        self.joint_count = len(self.joint_names)
        self.actuator = self._make_actuator(self.params)
        self.last_command_s: float | None = None
        self.effort_pub = self.create_publisher(Float64MultiArray, "/sim/effort", CONTROL_QOS)
        self.create_subscription(Float64MultiArray, "/joint_commands", self.command_callback, CONTROL_QOS)
        self.effort_msg = Float64MultiArray()
        # (receipt time, command) of recent commands, to pair with /controller/state
        self.recent_commands: deque[tuple[float, tuple[float, ...]]] = deque(maxlen=32)
        self.latency_pub = self.create_publisher(Float64MultiArray, "/motor/command_latency", CONTROL_QOS)
        self.create_subscription(Float64MultiArray, "/controller/state", self.controller_state_callback,
                                 CONTROL_QOS)
        self.latency_msg = Float64MultiArray()
        self.get_logger().info(f"motor: torque limit ±{self.actuator.torque_max.tolist()} N·m, "
                               f"lag {self.actuator.lag_time_constant_s:g} s")

    def _make_actuator(self, params: dict) -> Actuator:
        return Actuator(cfg.per_joint("torque_max", params["torque_max"], self.joint_count),
                        params["lag_time_constant_s"])

    def check_params(self, params: dict) -> None:
        if hasattr(self, "joint_count"):
            self._make_actuator(params)

    def apply_params(self, params: dict, changed: set[str]) -> None:
        self.actuator = self._make_actuator(params)

    def command_callback(self, msg: Float64MultiArray) -> None:
        checked = check_effort(msg.data, self.joint_count)
        if isinstance(checked, str):
            self.warn_throttled("command", f"/joint_commands dropped: {checked}")
            return
        now_s = self.now_s()
        self.recent_commands.append((now_s, tuple(msg.data)))
        dt = 0.0 if self.last_command_s is None else now_s - self.last_command_s
        self.last_command_s = now_s
        applied = self.actuator.apply(checked, dt)
        self.effort_msg.data = applied.tolist()
        self.effort_pub.publish(self.effort_msg)


    def controller_state_callback(self, msg: Float64MultiArray) -> None:
        try:
            state = state_layout.decode(np.asarray(msg.data), self.joint_count)
        except ValueError:
            return
        command = tuple(state["command"].tolist())
        for receipt_s, received in reversed(self.recent_commands):
            if received == command:
                self.latency_msg.data = [receipt_s - float(state["measurement_stamp_s"])]
                self.latency_pub.publish(self.latency_msg)
                return


def main(args: list[str] | None = None) -> int:
    return run(MotorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
