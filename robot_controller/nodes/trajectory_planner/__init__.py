"""trajectory_planner: the reference on ``/trajectory``, and the arm's face to ROS clients as ros2_controllers'
JointTrajectoryController shows it: ``/<controller_name>/joint_trajectory`` and the FollowJointTrajectory action."""

from robot_controller.nodes.trajectory_planner.node import TrajectoryPlanner, main

__all__ = ["TrajectoryPlanner", "main"]
