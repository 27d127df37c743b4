"""Identification of the real arm (``robot-controller identify``): the run (``excitation``), the fit
of each joint's four numbers (``joints``) or of a payload on a chain's last link (``payload``)."""

from robot_controller.experiments.identify.excitation import (
    AMPLITUDE_RAD,
    END_HZ,
    START_HZ,
    excitation_params,
    held_or_pushed,
    torque_limit,
)
from robot_controller.experiments.identify.experiment import identify

__all__ = ["AMPLITUDE_RAD", "END_HZ", "START_HZ", "excitation_params", "held_or_pushed", "identify", "torque_limit"]
