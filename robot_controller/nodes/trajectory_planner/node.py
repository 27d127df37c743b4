"""The planner node: the planner block (``blocks.planner``) stepped by its clock (``ros.planner_ticks``, chosen once
by ``ros.ticks``), its reference published through a gate (its time starts when the first consumer is matched), the
joint trajectory topics handed to it, and the FollowJointTrajectory action served beside it
(``follow_joint_trajectory``), and what the arm does handed to it (the brakes and the e-stop always, the readings and
the controller's state while a goal is in force)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from robot_controller.blocks import registry, spec
from robot_controller.blocks.planner import Planner
from robot_controller.nodes.trajectory_planner.follow_joint_trajectory import FollowJointTrajectoryServer
from robot_controller.ros.adapter import NodeLog
from robot_controller.ros.messages import decode, message_class
from robot_controller.ros.process import run
from robot_controller.ros.qos import CONTROL_QOS, ESTOP_QOS, LATEST_QOS
from robot_controller.ros.stack_node import StackNode
from robot_controller.ros.ticks import clock_mode, tick_source_class


class TrajectoryPlanner(StackNode):
    serves_actions = True  #: spun by an executor that serves action servers (ros.process.make_executor)

    def __init__(self) -> None:
        super().__init__("trajectory_planner")
        p = self.params
        self.block.start()
        self.pub = self.gated_publisher(Float64MultiArray, spec.REFERENCE.topic)
        self.msg = Float64MultiArray()
        n = p["joint_count"]
        self.msg.layout.dim = [
            MultiArrayDimension(label=name, size=n, stride=n) for name in ("position", "velocity", "acceleration")
        ]
        self.msg.layout.dim.append(MultiArrayDimension(label="time_s", size=1, stride=1))
        self.arm_subscriptions: list = []
        self.hear(spec.WAYPOINTS, LATEST_QOS)
        self.hear(spec.CONTROLLER_WAYPOINTS, LATEST_QOS)
        self.hear(spec.ESTOP, ESTOP_QOS)
        self.hear(spec.BRAKES, CONTROL_QOS)  # every change kept: an engagement released before a goal looks counts
        self.action = FollowJointTrajectoryServer(self, self.block)
        self.block.replaced.append(self.action.replaced)
        self.ticks = tick_source_class(self.get_name(), self.mode)(
            self, self.block, self.publish, ready=lambda: self.pub.open, monitor=self.action.monitor
        )
        self.ticks.start()
        self.get_logger().info(self.block.summary(", sim time" if self.mode.world_waits else ""))

    def setup(self, params: dict[str, Any]) -> None:
        self.block: Planner = registry.make(self.get_name(), params, NodeLog(self), clock_mode(params).world_waits)

    def check_params(self, params: dict[str, Any]) -> None:
        self.block.check_params(params)

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        self.block.set_params(params, changed, self.now_s())
        if "publish_rate_hz" in changed:
            self.ticks.retime()

    def now_s(self) -> float:
        """The planner's time, its clock's, s."""
        return self.ticks.now_s()

    def hear(self, port: spec.Port, qos: Any) -> Any:
        """A subscription handing ``port``'s messages to the block (:meth:`take`)."""
        topic = port.topic_for(self.params["controller_name"])
        return self.create_subscription(
            message_class(port.msg_type), topic, lambda msg, name=port.name: self.take(name, msg), qos
        )

    def take(self, port: str, msg: Any) -> None:
        """A message on ``port``, handed to the block as its value at the planner's time."""
        self.ticks.take(port, decode(msg))

    def listen_to_arm(self, on: bool) -> None:
        """Hear the arm only while a goal is in force. Two 100 Hz subscriptions cost the planner's executor (rclpy's
        single-threaded one, which rebuilds its wait set at every wake-up) a third of a CPU, taken from the loop on a
        busy host. Off, what was heard is forgotten: a next goal is never judged on an earlier one's estimate."""
        if on and not self.arm_subscriptions:
            self.block.arm.forget(self.now_s())
            self.arm_subscriptions = [self.hear(spec.READING, LATEST_QOS), self.hear(spec.STATE, LATEST_QOS)]
        elif not on and self.arm_subscriptions:
            for subscription in self.arm_subscriptions:
                self.destroy_subscription(subscription)
            self.arm_subscriptions = []
            self.block.arm.forget(self.now_s())

    def publish(self, outputs: Mapping[str, Any]) -> None:
        reference = outputs.get("reference")
        if reference is not None:
            self.msg.data = reference.data.tolist()
            self.pub.publish(self.msg)

    def finish(self) -> None:
        self.action.shutdown()
        super().finish()


def main(args: list[str] | None = None) -> int:
    return run(TrajectoryPlanner, args)


if __name__ == "__main__":
    raise SystemExit(main())
