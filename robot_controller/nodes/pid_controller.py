"""pid_controller: the control law at ``control_rate_hz``.

Reads ``/joint_states`` (noisy) and ``/trajectory``, publishes one torque
per joint on ``/joint_commands`` and every term on ``/controller/state``.
The maths is ``core.controller.JointController``; this node only converts
messages and parameters. The name stays ``pid_controller`` for the
tutorial's sake whatever law ``controller_type`` selects.
"""
from __future__ import annotations

from typing import Any

from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from robot_controller import config as cfg
from robot_controller import resources
from robot_controller.core import state_layout
from robot_controller.core.controller import JointController, Status
from robot_controller.core.plant import ArmDynamics
from robot_controller.core.validation import check_joint_state, check_trajectory
from robot_controller.nodes.base import CONTROL_QOS, StackNode, run, stamp_to_s


class PidControllerNode(StackNode):
    def __init__(self) -> None:
        super().__init__("pid_controller")
        self.dynamics = ArmDynamics(resources.resolve_urdf(self.params["urdf_path"]))
        self.joint_names = list(self.dynamics.joint_names)
        self.joint_count = len(self.joint_names)
        self.controller = JointController(cfg.controller_config(self.params, self.joint_count), self.joint_count,
                                          self.dynamics)
        self.command_pub = self.create_publisher(Float64MultiArray, "/joint_commands", CONTROL_QOS)
        self.state_pub = self.create_publisher(Float64MultiArray, "/controller/state", CONTROL_QOS)
        self.create_subscription(JointState, "/joint_states", self.joint_state_callback, CONTROL_QOS)
        self.create_subscription(Float64MultiArray, "/trajectory", self.trajectory_callback, CONTROL_QOS)
        self.timer = self.create_timer(1.0 / self.params["control_rate_hz"], self.control_callback)
        self.command_msg = Float64MultiArray()
        self.state_msg = Float64MultiArray()
        self.state_msg.layout.dim = (
            [MultiArrayDimension(label=name, size=1, stride=1) for name in state_layout.HEADER]
            + [MultiArrayDimension(label=name, size=self.joint_count, stride=self.joint_count)
               for name in state_layout.FIELDS])
        self.next_log_s = 0.0
        p = self.params
        self.get_logger().info(
            f"{p['controller_type'].upper()} controller at {p['control_rate_hz']:g} Hz on {self.joint_names}: "
            f"Kp={p['kp']}, Ki={p['ki']}, Kd={p['kd']}, derivative on {p['derivative_source']}, "
            f"feedforward {p['feedforward']}")

    def check_params(self, params: dict[str, Any]) -> None:
        if hasattr(self, "joint_count"):
            cfg.controller_config(params, self.joint_count)

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        self.controller.set_config(cfg.controller_config(params, self.joint_count))
        if "control_rate_hz" in changed:
            self.destroy_timer(self.timer)
            self.timer = self.create_timer(1.0 / params["control_rate_hz"], self.control_callback)

    def joint_state_callback(self, msg: JointState) -> None:
        checked = check_joint_state(msg.name, msg.position, msg.velocity, self.joint_names)
        if isinstance(checked, str):
            self.warn_throttled("joint_states", f"/joint_states dropped: {checked}")
            return
        self.controller.set_measurement(stamp_to_s(msg.header.stamp), self.now_s(), *checked)

    def trajectory_callback(self, msg: Float64MultiArray) -> None:
        checked = check_trajectory(msg.data, self.joint_count)
        if isinstance(checked, str):
            self.warn_throttled("trajectory", f"/trajectory dropped: {checked}")
            return
        self.controller.set_reference(self.now_s(), *checked)

    def control_callback(self) -> None:
        now_s = self.now_s()
        out = self.controller.update(now_s)
        if out.status is Status.NO_MEASUREMENT:
            self.warn_throttled("no_measurement", "no valid /joint_states yet: not commanding")
            return
        if out.status is Status.WATCHDOG:
            self.warn_throttled("watchdog", f"no valid /joint_states for over "
                                f"{self.controller.config.watchdog_periods} periods: zero torque")
        self.command_msg.data = out.command.tolist()
        self.command_pub.publish(self.command_msg)
        terms = out.terms
        self.state_msg.data = state_layout.encode(now_s, out.status.value, self.joint_count, {
            "reference": out.reference, "measured": out.measured, "error": out.error, "p": terms.p,
            "i": terms.i, "d": terms.d, "feedforward": terms.feedforward, "command": terms.command,
            "saturated": terms.saturated})
        self.state_pub.publish(self.state_msg)
        if now_s >= self.next_log_s:
            self.next_log_s = now_s + self.params["log_period_s"]
            self.get_logger().info(
                f"target={_fmt(out.reference)}, actual={_fmt(out.measured)}, error={_fmt(out.error)}, "
                f"torque={_fmt(out.command)}")


def _fmt(values: Any) -> str:
    return ",".join(f"{v:.3f}" for v in values)


def main(args: list[str] | None = None) -> int:
    return run(PidControllerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
