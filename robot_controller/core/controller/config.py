"""The joint controller's options (:class:`ControllerConfig`), checked when built.

Units: seconds, radians, N·m. The control law's own gains and limits are a
:class:`~robot_controller.core.laws.pid.PidConfig` inside it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.estimation import KalmanConfig
from robot_controller.core.laws import FeedforwardMode, lqr
from robot_controller.core.laws.pid import PidConfig, inertia_scaled
from robot_controller.core.laws.registry import BUILTIN_LAWS
from robot_controller.core.model.payload import torque_bound

#: s, the time over which an unknown payload's torque may change by its whole bound as the arm turns it
PAYLOAD_CHANGE_S = 1.0

if TYPE_CHECKING:
    from robot_controller.core.model import ArmDynamics


@dataclass
class ControllerConfig:
    """Options around the control law, every one given: each field is the ``pid_controller`` parameter of its name
    (the schema describes it and holds its default; ``parameters.builders`` makes this from the values), but for
    ``pid`` (the law's gains and limits), ``estimator`` (None: no filter), ``control_period_s`` (of
    ``control_rate_hz``) and the three the builder derives."""

    pid: PidConfig
    controller_type: str
    law_budget_s: float
    law_error_max_rad: float
    stop_law: str
    lqr_q: tuple[float, float, float]
    lqr_r: float | tuple[float, ...]  #: one for every joint, or one per joint
    reference_inertia: float
    rated_payload_kg: float
    model_drive_lag_s: float
    estimator: KalmanConfig | None
    disturbance_observer: bool
    inertia_adaptation: bool
    feedforward: FeedforwardMode
    feedback_decoupling: bool
    control_period_s: float
    reference_extrapolation: bool
    latency_compensation: bool
    #: each command acts from its tick and the world waits for it (sim time, the paced world): a world that
    #: went on without this controller's commands did so braked (the drive's timeout), until the next command
    world_waits: bool
    watchdog_periods: int
    sensor_timeout_s: float
    max_reading_age_s: float
    stop_deceleration: float
    reacquire_acceleration: float
    design_position: tuple[float, ...] | None  #: None: every joint at 0
    min_delay_margin_periods: int
    #: a plugin law's parameter values, by the names it declares (checked against them when it is built)
    law_parameters: dict[str, Any] = field(default_factory=dict)
    #: the gains (of kp, ki, kd) given as one value on a chain: for a joint of reference_inertia, scaled per joint
    scaled_gains: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        try:
            self.feedforward = FeedforwardMode(self.feedforward)
        except ValueError:
            raise ConfigError(
                f"feedforward: {self.feedforward!r} is not one of {[m.value for m in FeedforwardMode]}"
            ) from None
        if not np.isfinite(self.control_period_s) or self.control_period_s <= 0:
            raise ConfigError(f"control_rate_hz: must be > 0, got period {self.control_period_s}")
        if int(self.watchdog_periods) < 1:
            raise ConfigError(f"watchdog_periods: must be >= 1, got {self.watchdog_periods}")
        for name in ("sensor_timeout_s", "max_reading_age_s", "stop_deceleration", "reacquire_acceleration"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ConfigError(f"{name}: must be a finite number > 0, got {value}")
        if not isinstance(self.controller_type, str) or not self.controller_type.strip():
            raise ConfigError("controller_type: give pid, lqr, an installed law, module:Class or file.py:Class")
        if self.stop_law not in BUILTIN_LAWS:
            raise ConfigError(f"stop_law: {self.stop_law!r} is not one of {list(BUILTIN_LAWS)}")
        if not np.isfinite(self.law_budget_s) or self.law_budget_s <= 0:
            raise ConfigError(f"law_budget_s: must be a finite number > 0, got {self.law_budget_s}")
        if not np.isfinite(self.law_error_max_rad) or self.law_error_max_rad < 0:
            raise ConfigError(f"law_error_max_rad: must be a finite number >= 0, got {self.law_error_max_rad}")

    @property
    def plugin_law(self) -> bool:
        """Whether the law is one of the user's (not a built-in)."""
        return self.controller_type not in BUILTIN_LAWS

    @property
    def builtin_law(self) -> str:
        """The built-in law this config runs: ``controller_type``, or for a plugin law ``stop_law``."""
        return self.stop_law if self.plugin_law else self.controller_type

    @property
    def observes_disturbance(self) -> bool:
        """Whether the disturbance observer runs: asked for, and there is a Kalman filter to carry it."""
        return bool(self.disturbance_observer) and self.estimator is not None

    def law_params(self) -> dict[str, Any]:
        """The built-in law's parameters (:class:`~robot_controller.core.laws.pid.BuiltinLaw`)."""
        return {
            "pid": self.pid,
            "feedforward": self.feedforward,
            "feedback_decoupling": self.feedback_decoupling,
            "lqr_q": self.lqr_q,
            "lqr_r": self.lqr_r,
            "reference_inertia": self.reference_inertia,
            "design_position": self.design_position,
            "scaled_gains": self.scaled_gains,
            "rated_payload_kg": self.rated_payload_kg,
        }

    def observer_torque_scale(self, dynamics: ArmDynamics, joint_count: int) -> np.ndarray | None:
        """Per joint, the factor on the disturbance observer's torque σs: the joint's inertia over
        ``reference_inertia`` (None when that is 0: the σs as they are)."""
        if self.reference_inertia <= 0:
            return None
        return lqr.design_inertia(dynamics, joint_count, self.design_position) / self.reference_inertia

    def payload_torque_std(self, dynamics: ArmDynamics, joint_count: int) -> np.ndarray | None:
        """Per joint, N·m/√s: the observer's extra mismatch σ for a payload up to ``rated_payload_kg`` the model
        lacks (its gravity torque at the design pose, :func:`torque_bound`, over PAYLOAD_CHANGE_S); None: none."""
        if self.rated_payload_kg <= 0 or not self.observes_disturbance or getattr(dynamics, "model", None) is None:
            return None
        pose = np.zeros(joint_count) if self.design_position is None else np.asarray(self.design_position, float)
        return torque_bound(dynamics.model, self.rated_payload_kg, pose) / np.sqrt(PAYLOAD_CHANGE_S)


def law_config(
    config: ControllerConfig, dynamics: ArmDynamics | None, joint_count: int, kind: str | None = None
) -> PidConfig:
    """The PID settings the built-in law ``kind`` ("pid" or "lqr"; None: :attr:`ControllerConfig.builtin_law`)
    runs with: for LQR, the designed gains (``ConfigError`` if there is no design); for PID, the gains
    given as one value scaled by each joint's inertia (:func:`~robot_controller.core.laws.pid.inertia_scaled`)."""
    if (kind or config.builtin_law) == "pid":
        position, scaled = config.design_position, config.scaled_gains
        return inertia_scaled(config.pid, dynamics, joint_count, config.reference_inertia, position, scaled)
    return lqr.designed_gains(
        config.pid,
        dynamics,
        joint_count,
        config.control_period_s,
        config.lqr_q,
        config.lqr_r,
        config.reference_inertia,
        config.design_position,
        config.rated_payload_kg,
    )
