"""ament_python entry point: colcon on a full ROS 2 install builds from here.

Metadata lives in pyproject.toml; this adds the ROS share/ layout (package
marker, package.xml, config, robot description and launch files) that `ros2 run` and
`ros2 launch` look for.
"""

from glob import glob

from setuptools import setup

PACKAGE = "robot_controller"

setup(
    data_files=[
        ("share/ament_index/resource_index/packages", [f"resource/{PACKAGE}"]),
        (f"share/{PACKAGE}", ["package.xml"]),
        (f"share/{PACKAGE}/config", glob("config/*.yaml") + glob("config/*.xml")),
        (f"share/{PACKAGE}/config/presets", glob("config/presets/*.yaml")),
        (f"share/{PACKAGE}/description", glob("description/*.urdf")),
        (f"share/{PACKAGE}/launch", glob("launch/*.launch.py")),
    ],
)
