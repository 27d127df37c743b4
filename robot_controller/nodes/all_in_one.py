"""All five nodes in one process on one executor (the composition mode):
same topics, same parameters, no inter-process hops."""

from __future__ import annotations

from robot_controller.nodes.motor_node import MotorNode
from robot_controller.nodes.pid_controller import ControllerNode
from robot_controller.nodes.sensor_node import SensorNode
from robot_controller.nodes.simulator import Simulator
from robot_controller.nodes.trajectory_planner import TrajectoryPlanner
from robot_controller.ros.process import run


def main(args: list[str] | None = None) -> int:
    return run([Simulator, MotorNode, SensorNode, ControllerNode, TrajectoryPlanner], args)


if __name__ == "__main__":
    raise SystemExit(main())
