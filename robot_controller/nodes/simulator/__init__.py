"""simulator: the physics world (the Gazebo role). MuJoCo steps the arm from the URDF at ``physics_rate_hz`` on the
latest effort (port ``effort``); the true state goes out (port ``true_state``), stamped with its physics time."""

from robot_controller.nodes.simulator.node import Simulator, main

__all__ = ["Simulator", "main"]
