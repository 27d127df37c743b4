"""Identification of the real arm (``robot-controller identify``): the run (``excitation``), the fit
of each joint's four numbers (``joints``) or of a payload on a chain's last link (``payload``)."""

from robot_controller.experiments.identify.experiment import identify

__all__ = ["identify"]
