"""A drive whose torque follows its command through a first-order lag, as the drive applies it: each command moves
the torque applied a share ``period / (lag + period)`` of the way from where it was to the command, and the torque is
then held until the next (:class:`~robot_controller.core.model.actuator.Actuator`). A controller that knows the lag
inverts it exactly (:class:`LagInversion`): it commands whatever moves the torque applied to the torque its law wants,
so its law, its filter and its feedforward see a drive without lag; ``identify`` finds the lag from the commands and
the torques applied (:func:`fit_lag`).

Why invert rather than design for it: the lag's 20 ms at 100 Hz is two periods of phase the LQR's delay margin would
have to give up on every joint, where the inversion costs nothing while the command stays within the torque limit.
Inverting a lag the drive does not have (or more than it has) drives the torque past the command and back: it stays
stable up to twice the drive's share, so a lag identified within a factor of two of the true one is safe."""

from __future__ import annotations

import numpy as np


def lag_share(lag_s: float, period_s: float) -> float:
    """The share of the way from the torque applied to the command a command covers after ``period_s`` (1: no lag)."""
    return period_s / (lag_s + period_s) if period_s > 0 else 0.0


class LagInversion:
    """The commands that make a drive of ``lag_s`` apply the torques a law wants, within ``±torque_max`` (N·m per
    joint); ``applied`` is the torque the drive applies after each command, as it computes it."""

    def __init__(self, lag_s: float, torque_max: np.ndarray) -> None:
        self.lag_s = float(lag_s)
        self._high = np.asarray(torque_max, dtype=float)
        self._low = -self._high
        self.applied = np.zeros_like(self._high)  #: N·m per joint, the torque the drive applies now
        self._started = False  #: a command since the start (or the last reset): the drive's lag has a period

    def reset(self) -> None:
        """The drive stopped applying torque (a brake, a timeout, an e-stop): its lag starts again from zero, and its
        first command after moves nothing (no period yet to move over)."""
        self.applied = np.zeros_like(self._high)
        self._started = False

    def command(self, wanted: np.ndarray, period_s: float) -> np.ndarray:
        """The command (N·m per joint) that moves the torque applied to ``wanted`` after ``period_s`` at the last one,
        within the torque limit (where it is not, the torque applied goes as far as the limit takes it)."""
        share = lag_share(self.lag_s, period_s) if self._started else 0.0
        self._started = True
        if share <= 0:
            return np.minimum(np.maximum(wanted, self._low), self._high)
        command = self.applied + (np.asarray(wanted, dtype=float) - self.applied) / share
        command = np.minimum(np.maximum(command, self._low), self._high)
        self.applied = self.applied + share * (command - self.applied)
        return command


def fit_lag(command: np.ndarray, applied: np.ndarray, period_s: float) -> tuple[float, float]:
    """The drive's lag (s) and its standard error from the commands (a row per period, a column per joint) and the
    torque applied over each period, taken where the torque moved (the least-squares share of each step
    ``applied[k] − applied[k−1] = share·(command[k] − applied[k−1])``, every joint together). (0, 0): no lag found
    (no step, or a share at or above 1)."""
    command, applied = np.asarray(command, dtype=float), np.asarray(applied, dtype=float)
    moved = applied[1:] - applied[:-1]
    asked = command[1:] - applied[:-1]
    used = np.abs(asked) > 1e-9
    x, y = asked[used], moved[used]
    if x.size < 3 or not np.any(x):
        return 0.0, 0.0
    share = float(x @ y / (x @ x))
    if share >= 1.0 or share <= 0.0:
        return 0.0, 0.0
    residual = y - share * x
    share_stderr = float(np.sqrt(residual @ residual / (x.size - 1) / (x @ x)))
    lag_s = period_s * (1.0 / share - 1.0)
    return lag_s, period_s * share_stderr / share**2  # (d lag / d share = −period / share²)
