"""The controller's tick: supervision of its inputs, the state and the reference at the tick, the
law in force, the controlled stops, and what one tick outputs (:mod:`.controller` runs it)."""

from robot_controller.core.controller.config import ControllerConfig, law_config
from robot_controller.core.controller.controller import JointController
from robot_controller.core.controller.supervision import (
    ControlOutput,
    Status,
    check_delay_margin,
    delay_margin_periods,
)

__all__ = [
    "ControlOutput",
    "ControllerConfig",
    "JointController",
    "Status",
    "check_delay_margin",
    "delay_margin_periods",
    "law_config",
]
