"""Control laws: the interface every law implements, the built-in PID and LQR among them
(:mod:`.interface`, :mod:`.pid` with its model feedforward, :mod:`.lqr`), their
stability and delay margins (:mod:`.robustness`), how ``controller_type`` names one
(:mod:`.registry`) and its parameters are checked (:mod:`.law_parameters`), and how the controller
contains a user's law, a law itself that checks every call (:mod:`.containment`). A law of
one's own needs only ``from robot_controller.core.laws import ControlLaw, Parameter``."""

from robot_controller.core.laws.containment import ContainedLaw, LawFault
from robot_controller.core.laws.interface import Arm, ControlLaw, Parameter, Reference, State
from robot_controller.core.laws.lqr import LqrLaw
from robot_controller.core.laws.pid import (
    AntiWindup,
    BuiltinLaw,
    DerivativeSource,
    FeedforwardMode,
    Pid,
    PidConfig,
    PidLaw,
    PidTerms,
    decoupling_map,
    feedforward_torque,
)

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
