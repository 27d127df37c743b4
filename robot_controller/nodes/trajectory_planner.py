"""trajectory_planner: the reference (port ``reference``), and the arm's face to ROS clients as ros2_controllers'
JointTrajectoryController shows it. The planner block (``blocks.planner``) hosted by the adapter (``ros.adapter``),
stepped by its clock (``ros.ticks``); beside it, the FollowJointTrajectory action (``follow_joint_trajectory``),
its waypoint topics under ``controller_name`` (port ``controller_waypoints``), and what the arm does heard (the brakes
and the e-stop always, the readings and the controller's state only while a goal is in force)."""

from __future__ import annotations

from typing import Any

from robot_controller.blocks import spec
from robot_controller.nodes.follow_joint_trajectory import FollowJointTrajectoryServer
from robot_controller.ros.adapter import BlockNode, Extras
from robot_controller.ros.process import run
from robot_controller.ros.qos import CONTROL_QOS, ESTOP_QOS, LATEST_QOS

# What it hears from the start (the arm's readings and state: while a goal is in force). The brakes: every change
# kept, as an engagement released before a goal looks counts.
HEARD_QOS = {"waypoints": LATEST_QOS, "controller_waypoints": LATEST_QOS, "estop": ESTOP_QOS, "brakes": CONTROL_QOS}


class PlannerExtras(Extras):
    def __init__(self, node: BlockNode) -> None:
        super().__init__(node)
        self.arm_subscriptions: list = []
        self.action: FollowJointTrajectoryServer | None = None

    def reader_qos(self, port: spec.Port) -> Any:
        return HEARD_QOS.get(port.name)

    def topic(self, port: spec.Port) -> str:
        return port.topic_for(self.node.params["controller_name"])

    def watched(self, port: spec.Port) -> bool:
        return False

    def layout(self, port: spec.Port) -> list[tuple[str, int]]:
        n = self.node.params["joint_count"]
        return [("position", n), ("velocity", n), ("acceleration", n), ("time_s", 1)]

    def make_ticks(self, source: type) -> Any:
        node = self.node
        self.action = FollowJointTrajectoryServer(node, node.block, now_s=self.now_s, listen=self.listen_to_arm)
        node.block.replaced.append(self.action.replaced)
        gate = node.publishers_by_port["reference"][0]
        return source(node, node.block, node.publish, ready=lambda: gate.open, monitor=self.action.monitor)

    def start(self) -> None:
        sim_time = ", sim time" if self.node.mode.world_waits else ""
        self.node.get_logger().info(self.node.block.summary(sim_time))

    def now_s(self) -> float:
        """The planner's time, its clock's, s."""
        return self.node.ticks.now_s()

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        self.node.block.set_params(params, changed, self.now_s())
        if "publish_rate_hz" in changed:
            self.node.ticks.retime()

    def listen_to_arm(self, on: bool) -> None:
        """Hear the arm only while a goal is in force. Two 100 Hz subscriptions cost the planner's executor (rclpy's
        single-threaded one, which rebuilds its wait set at every wake-up) a third of a CPU, taken from the loop on a
        busy host. Off, what was heard is forgotten: a next goal is never judged on an earlier one's estimate."""
        node = self.node
        if on and not self.arm_subscriptions:
            node.block.arm.forget(self.now_s())
            self.arm_subscriptions = [node.hear(spec.READING, LATEST_QOS), node.hear(spec.STATE, LATEST_QOS)]
        elif not on and self.arm_subscriptions:
            for subscription in self.arm_subscriptions:
                node.destroy_subscription(subscription)
            self.arm_subscriptions = []
            node.block.arm.forget(self.now_s())

    def finish(self) -> None:
        if self.action is not None:
            self.action.shutdown()


def TrajectoryPlanner() -> BlockNode:  # noqa: N802 (made as a node class is, by ``ros.process.run``)
    return BlockNode("trajectory_planner", PlannerExtras)


TrajectoryPlanner.serves_actions = True  # spun by an executor that serves action servers (ros.process.make_executor)


def main(args: list[str] | None = None) -> int:
    return run(TrajectoryPlanner, args)


if __name__ == "__main__":
    raise SystemExit(main())
