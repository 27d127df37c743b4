"""Control laws: the interface every law implements, the built-in PID and LQR among them
(:mod:`.interface`, :mod:`.builtin` with its model feedforward, :mod:`.pid`, :mod:`.lqr`), their
stability and delay margins (:mod:`.robustness`), how ``controller_type`` names one
(:mod:`.registry`) and its parameters are checked (:mod:`.parameters`), and how the controller
contains a user's law, a law itself that checks every call (:mod:`.containment`). A law of
one's own needs only ``from robot_controller.core.laws import ControlLaw, Parameter``."""

from robot_controller.core.laws.builtin import (
    BuiltinLaw,
    FeedforwardMode,
    LqrLaw,
    PidLaw,
    decoupling_map,
    feedforward_torque,
)
from robot_controller.core.laws.containment import ContainedLaw, LawFault
from robot_controller.core.laws.interface import Arm, ControlLaw, Parameter, Reference, State
from robot_controller.core.laws.pid import AntiWindup, DerivativeSource, Pid, PidConfig, PidTerms

__all__ = [
    "AntiWindup",
    "Arm",
    "BuiltinLaw",
    "ContainedLaw",
    "ControlLaw",
    "DerivativeSource",
    "FeedforwardMode",
    "LawFault",
    "LqrLaw",
    "Parameter",
    "Pid",
    "PidConfig",
    "PidLaw",
    "PidTerms",
    "Reference",
    "State",
    "decoupling_map",
    "feedforward_torque",
]
