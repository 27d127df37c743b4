"""The robots ``--robot`` selects (``description``): four built in, or any fixed-base arm's description made loadable:
an example-robot-data arm by name, a URDF or MJCF path, a ``package://`` URI."""

from robot_controller.robots.description import DEFAULT_ROBOT, ROBOTS, arm_name, robot, urdf_of

__all__ = ["DEFAULT_ROBOT", "ROBOTS", "arm_name", "robot", "urdf_of"]
