"""Actuator model: torque saturation and an optional first-order lag."""

from __future__ import annotations

import math

import numpy as np

from robot_controller.core.errors import ConfigError


class Actuator:
    """Turns commanded torque into applied torque.

    :param torque_max: symmetric limit per joint, N·m (> 0)
    :param lag_time_constant_s: first-order lag time constant, s (0 = none)
    """

    def __init__(self, torque_max: np.ndarray, lag_time_constant_s: float = 0.0) -> None:
        torque_max = np.atleast_1d(np.asarray(torque_max, dtype=float))
        if not np.all(np.isfinite(torque_max)) or np.any(torque_max <= 0):
            raise ConfigError(f"torque_max: must be finite and > 0, got {torque_max.tolist()}")
        if not np.isfinite(lag_time_constant_s) or lag_time_constant_s < 0:
            raise ConfigError(f"lag_time_constant_s: must be a finite number >= 0, got {lag_time_constant_s}")
        self.torque_max = torque_max
        self._low = -torque_max
        self.lag_time_constant_s = float(lag_time_constant_s)
        self._applied = np.zeros_like(torque_max)

    @property
    def applied(self) -> np.ndarray:
        """The torque being applied now, N·m."""
        return self._applied.copy()

    def reset(self) -> None:
        """Torque off at once (a stop), the lag starting again from zero."""
        self._applied = np.zeros_like(self.torque_max)

    def apply(self, command: np.ndarray, dt: float) -> np.ndarray:
        """Take a new command after ``dt`` seconds at the old one; return the applied torque, within
        ``±torque_max`` (non-finite entries count as zero)."""
        finite = np.isfinite(command)
        if np.count_nonzero(finite) != finite.size:
            command = np.where(finite, command, 0.0)
        target = np.minimum(np.maximum(command, self._low), self.torque_max)  # np.clip, without its wrapper
        if self.lag_time_constant_s > 0 and math.isfinite(dt) and dt >= 0:
            alpha = dt / (self.lag_time_constant_s + dt) if dt > 0 else 0.0
            self._applied = self._applied + alpha * (target - self._applied)
        else:
            self._applied = target
        return self._applied.copy()
