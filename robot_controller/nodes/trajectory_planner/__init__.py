"""trajectory_planner: the reference (port ``reference``), and the arm's face to ROS clients as ros2_controllers'
JointTrajectoryController shows it: its waypoints topic (port ``controller_waypoints``) and the FollowJointTrajectory
action (``blocks.spec``)."""

from robot_controller.nodes.trajectory_planner.node import TrajectoryPlanner, main

__all__ = ["TrajectoryPlanner", "main"]
