"""The robots ``--robot`` selects (``catalogue``): four built in, or any fixed-base arm's description
made loadable (``description``): an example-robot-data arm by name, a URDF or MJCF path, a ``package://`` URI."""

from robot_controller.robots.catalogue import DEFAULT_ROBOT, ROBOTS, Robot, arm_name, robot, urdf_of

__all__ = ["DEFAULT_ROBOT", "ROBOTS", "Robot", "arm_name", "robot", "urdf_of"]
