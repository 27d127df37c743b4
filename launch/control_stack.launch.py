"""The control stack as the tutorial launches it: sensor, controller and
planner, plus the motor between the controller and the arm.

    ros2 launch robot_controller control_stack.launch.py [params_file:=my.yaml]

Start the arm with ``robot.launch.py`` (the MuJoCo simulator). Every node has
its defaults built in (``robot-controller params`` lists them); a
``params_file`` (ROS 2 parameter file, e.g. from ``robot-controller params
--yaml``) overrides them. Node names are the executables' own, which the
parameter files and the nodes' input checks expect.
"""

from launch_ros.actions import Node

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration

NODES = ("motor_node", "sensor_node", "pid_controller", "trajectory_planner")


def _nodes(context):
    params_file = LaunchConfiguration("params_file").perform(context)
    parameters = [params_file] if params_file else []
    return [
        Node(package="robot_controller", executable=name, name=name, output="screen", parameters=parameters)
        for name in NODES
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
