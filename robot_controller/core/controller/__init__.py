"""The controller's tick: supervision of its inputs, the state and the reference at the tick, the
law in force, the controlled stops, and what one tick outputs (:mod:`.controller` runs it)."""

from robot_controller.core.controller.config import ControllerConfig, law_config
from robot_controller.core.controller.controller import STOPS, JointController
from robot_controller.core.controller.reference_in_force import REFERENCE_TIMEOUT_PERIODS, PlannerReference
from robot_controller.core.controller.supervision import (
    REACQUIRE_GAP_PERIODS,
    ControlOutput,
    LatencyGuard,
    LatencyState,
    Readings,
    ReferenceSource,
    Status,
    TickClock,
    check_delay_margin,
    check_health,
    delay_margin_periods,
)

__all__ = [
    "REACQUIRE_GAP_PERIODS",
    "REFERENCE_TIMEOUT_PERIODS",
    "STOPS",
    "ControlOutput",
    "ControllerConfig",
    "JointController",
    "LatencyGuard",
    "LatencyState",
    "PlannerReference",
    "ReferenceSource",
    "Readings",
    "Status",
    "TickClock",
    "check_delay_margin",
    "check_health",
    "delay_margin_periods",
    "law_config",
]
