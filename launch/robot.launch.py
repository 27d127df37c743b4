"""The arm: the MuJoCo simulator (the Gazebo role in the tutorial).

    ros2 launch robot_controller robot.launch.py [params_file:=my.yaml]

It holds the arm on its brakes until the first effort arrives, so it may
start before or after ``control_stack.launch.py``.
"""

from launch_ros.actions import Node

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration


def _nodes(context):
    params_file = LaunchConfiguration("params_file").perform(context)
    return [
        Node(
            package="robot_controller",
            executable="simulator",
            name="simulator",
            output="screen",
            parameters=[params_file] if params_file else [],
        )
    ]


def generate_launch_description():
    return LaunchDescription(
        [
            DeclareLaunchArgument(
                "params_file", default_value="", description="ROS 2 parameter file over the built-in defaults"
            ),
            OpaqueFunction(function=_nodes),
        ]
    )
