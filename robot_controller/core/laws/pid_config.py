"""The PID law's settings (:class:`PidConfig`, with its :class:`AntiWindup` and
:class:`DerivativeSource` options, checked when built) and what one step
reports (:class:`PidTerms`). Units: N·m, rad, s."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from robot_controller.core.errors import ConfigError


class AntiWindup(str, Enum):
    """How the integral is kept from winding up while the output saturates."""

    NONE = "none"
    CLAMP = "clamp"  #: |∫e dt| ≤ integral_limit (rad·s), the tutorial's clamp
    BACK_CALCULATION = "back_calculation"  #: bleed (u_sat − u)/Tt into the I term
    CONDITIONAL_INTEGRATION = "conditional_integration"  #: freeze while saturated and error pushes further out


class DerivativeSource(str, Enum):
    """What the D term differentiates."""

    MEASURED_VELOCITY = "measured_velocity"  #: −v_measured, the tutorial's choice
    VELOCITY_ERROR = "velocity_error"  #: v_reference − v_measured
    ERROR = "error"  #: finite difference of the position error
    MEASUREMENT = "measurement"  #: −finite difference of the measured position


@dataclass
class PidConfig:
    """Gains and options of :class:`Pid`.

    :param kp: proportional gain, N·m/rad, per joint
    :param ki: integral gain, N·m/(rad·s), per joint
    :param kd: derivative gain, N·m·s/rad, per joint
    :param output_limit: symmetric torque limit, N·m (> 0), per joint
    :param integral_limit: clamp on ∫e dt, rad·s (used by ``clamp``)
    :param anti_windup: an :class:`AntiWindup` mode
    :param back_calculation_time_s: tracking time constant Tt of back-calculation, s
    :param derivative_source: a :class:`DerivativeSource`
    :param derivative_filter_time_s: first-order low-pass time constant on the D signal, s (0 = off)
    :param slew_rate_limit: max |du/dt|, N·m/s (0 = off)
    """

    kp: np.ndarray = field(default_factory=lambda: np.array([50.0]))
    ki: np.ndarray = field(default_factory=lambda: np.array([10.0]))
    kd: np.ndarray = field(default_factory=lambda: np.array([5.0]))
    output_limit: np.ndarray = field(default_factory=lambda: np.array([10.0]))
    integral_limit: np.ndarray = field(default_factory=lambda: np.array([10.0]))
    anti_windup: AntiWindup = AntiWindup.CLAMP
    back_calculation_time_s: float = 0.1
    derivative_source: DerivativeSource = DerivativeSource.MEASURED_VELOCITY
    derivative_filter_time_s: float = 0.0
    slew_rate_limit: float = 0.0

    def __post_init__(self) -> None:
        for name in ("kp", "ki", "kd", "output_limit", "integral_limit"):
            value = np.atleast_1d(np.asarray(getattr(self, name), dtype=float))
            if not np.all(np.isfinite(value)):
                raise ConfigError(f"{name}: must be finite, got {value.tolist()}")
            if np.any(value < 0):
                raise ConfigError(f"{name}: must be >= 0, got {value.tolist()}")
            setattr(self, name, value)
        if np.any(self.output_limit <= 0):
            raise ConfigError(f"output_limit: must be > 0, got {self.output_limit.tolist()}")
        try:
            self.anti_windup = AntiWindup(self.anti_windup)
        except ValueError:
            raise ConfigError(
                f"anti_windup: {self.anti_windup!r} is not one of {[m.value for m in AntiWindup]}"
            ) from None
        try:
            self.derivative_source = DerivativeSource(self.derivative_source)
        except ValueError:
            raise ConfigError(
                f"derivative_source: {self.derivative_source!r} is not one of " f"{[m.value for m in DerivativeSource]}"
            ) from None
        for name in ("back_calculation_time_s", "derivative_filter_time_s", "slew_rate_limit"):
            value = float(getattr(self, name))
            if not np.isfinite(value) or value < 0:
                raise ConfigError(f"{name}: must be a finite number >= 0, got {value}")
            setattr(self, name, value)
        if self.anti_windup is AntiWindup.BACK_CALCULATION and self.back_calculation_time_s <= 0:
            raise ConfigError("back_calculation_time_s: must be > 0 with anti_windup back_calculation")


@dataclass
class PidTerms:
    """One step's output and its parts, for tuning plots (all N·m except ``saturated``)."""

    command: np.ndarray
    p: np.ndarray
    i: np.ndarray
    d: np.ndarray
    feedforward: np.ndarray
    saturated: np.ndarray  #: bool per joint: the limit (output or slew) cut the command
