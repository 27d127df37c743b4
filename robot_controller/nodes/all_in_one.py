"""All five nodes in one process on one executor (the composition mode):
same topics, same parameters, no inter-process hops."""
from __future__ import annotations

import gc
import sys

import rclpy
from rclpy.executors import ExternalShutdownException

from robot_controller.core.errors import ConfigError
from robot_controller.nodes.base import (exit_after_cleanup_timeout, init_with_own_signals, make_executor,
                                         request_realtime_priority, shutting_down, spin)
from robot_controller.nodes.motor_node import MotorNode
from robot_controller.nodes.pid_controller import PidControllerNode
from robot_controller.nodes.sensor_node import SensorNode
from robot_controller.nodes.simulator import Simulator
from robot_controller.nodes.trajectory_planner import TrajectoryPlanner


def main(args: list[str] | None = None) -> int:
    priority_note = request_realtime_priority()
    init_with_own_signals(args)
    nodes = []
    code = [0]
    executor = make_executor()
    try:
        for node_class in (Simulator, MotorNode, SensorNode, PidControllerNode, TrajectoryPlanner):
            nodes.append(node_class())
            executor.add_node(nodes[-1])
        if priority_note:
            nodes[0].get_logger().info(priority_note)
        gc.freeze()  # as in base.run: long-lived start-up objects out of full collections
        spin(executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RuntimeError:
        # A signal can shut the context down while a callback is taking a
        # message; that is a normal stop, anything else is not.
        if not shutting_down():
            raise
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr, flush=True)
        code[0] = 2
    finally:
        guard = exit_after_cleanup_timeout(code)
        executor.shutdown(timeout_sec=1.0)
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
        guard.cancel()
    return code[0]


if __name__ == "__main__":
    raise SystemExit(main())
