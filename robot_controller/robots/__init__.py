"""The robots ``--robot NAME`` selects (``catalogue``), and the Panda made loadable (``panda``)."""

from robot_controller.robots.catalogue import DEFAULT_ROBOT, ROBOTS, Robot, robot, urdf_of

__all__ = ["DEFAULT_ROBOT", "ROBOTS", "Robot", "robot", "urdf_of"]
