"""Control laws as plugins: the interface a law implements (:mod:`.interface`),
how ``controller_type`` names one (:mod:`.registry`), and how the framework
contains one that misbehaves (:mod:`.containment`). A law of one's own needs
only ``from robot_controller.core.laws import ControlLaw, Parameter``."""

from robot_controller.core.laws.interface import Arm, ControlLaw, Parameter, Reference, State

__all__ = ["Arm", "ControlLaw", "Parameter", "Reference", "State"]
