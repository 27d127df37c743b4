"""References for when a loop is not simply tracking: a controlled stop when an input is lost (category 2) and a
blend back onto the trajectory when it returns, per joint, limited in acceleration. Pure functions of time."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ControlledStop:
    """Decelerate from ``(position, velocity)`` at ``start_s`` at ``deceleration`` (rad/s², per joint) to rest, hold."""

    start_s: float
    position: np.ndarray
    velocity: np.ndarray
    deceleration: float

    def at(self, time_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(position, velocity, acceleration)`` at ``time_s``."""
        v0 = np.asarray(self.velocity, dtype=float)
        stop_after = np.abs(v0) / self.deceleration  # per joint, s
        tau = np.clip(time_s - self.start_s, 0.0, stop_after)
        accel = -np.sign(v0) * self.deceleration
        position = self.position + v0 * tau + 0.5 * accel * tau * tau
        velocity = v0 + accel * tau
        moving = (time_s - self.start_s) < stop_after
        return position, np.where(moving, velocity, 0.0), np.where(moving, accel, 0.0)

    def at_rest(self, time_s: float) -> bool:
        return bool(np.all(time_s - self.start_s >= np.abs(self.velocity) / self.deceleration))


@dataclass(frozen=True)
class SmoothStop:
    """To rest from ``(position, velocity, acceleration)`` at ``start_s`` along a quintic per joint (position, speed and
    acceleration continuous: no torque step, which a drive's rate limit would smear into a tracking error), its
    acceleration within ``deceleration`` (or the one it starts with, if more); held after ``duration_s``."""

    start_s: float
    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    duration_s: float

    @classmethod
    def starting(
        cls, start_s: float, position: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray, deceleration: float
    ) -> SmoothStop:
        v0, a0 = np.asarray(velocity, float), np.asarray(acceleration, float)
        duration = max(MIN_STOP_S, 1.5 * float(np.max(np.abs(v0))) / deceleration)
        probe = np.linspace(0.0, 1.0, 41)[:, None]
        bound = np.maximum(deceleration, np.abs(a0)) + 1e-9
        stop = cls(start_s, np.asarray(position, float), v0, a0, duration)
        for _ in range(40):  # ×1.25 each: ends
            stop = cls(start_s, stop.position, v0, a0, duration)
            if np.all(np.abs(stop._at(probe * duration)[2]) <= bound):
                break
            duration *= 1.25
        return stop

    def _at(self, tau):
        """Position, velocity, acceleration ``tau`` s into the stop (a float, or a column of them)."""
        T, p0, v0, a0 = self.duration_s, self.position, self.velocity, self.acceleration
        # The quintic with p(0)=p0, v(0)=v0, a(0)=a0, v(T)=a(T)=0, its end where a constant jerk would bring it:
        # p(T) = p0 + v0·T/2 + a0·T²/12.
        end = p0 + v0 * T / 2 + a0 * T**2 / 12
        s = np.clip(tau / T, 0.0, 1.0)
        d = end - p0 - v0 * T - a0 * T**2 / 2  # what the quintic's last three terms must add
        dv, da = -v0 - a0 * T, -a0  # at T, the velocity and acceleration they must cancel
        c3 = (10 * d - 4 * dv * T + da * T**2 / 2) / T**3
        c4 = (-15 * d + 7 * dv * T - da * T**2) / T**4
        c5 = (6 * d - 3 * dv * T + da * T**2 / 2) / T**5
        t = s * T
        position = p0 + v0 * t + a0 * t**2 / 2 + c3 * t**3 + c4 * t**4 + c5 * t**5
        velocity = v0 + a0 * t + 3 * c3 * t**2 + 4 * c4 * t**3 + 5 * c5 * t**4
        acceleration = a0 + 6 * c3 * t + 12 * c4 * t**2 + 20 * c5 * t**3
        return position, velocity, acceleration

    def at(self, time_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(position, velocity, acceleration)`` at ``time_s``."""
        return self._at(time_s - self.start_s)

    def at_rest(self, time_s: float) -> bool:
        return time_s - self.start_s >= self.duration_s


#: s the shortest smooth stop takes
MIN_STOP_S = 0.1


def _quintic(
    p0: np.ndarray, v0: np.ndarray, duration_s: float, tau: float | np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The quintic from ``(p0, v0, 0)`` at 0 to ``(0, 0, 0)`` at ``duration_s``, at ``tau`` (s, or a column)."""
    T = duration_s
    s = tau / T
    s = min(max(s, 0.0), 1.0) if isinstance(s, float) else np.clip(s, 0.0, 1.0)  # (a float's weights: floats)
    a, da, dda, b, db, ddb = _quintic_weights(s, T)
    return p0 * a + v0 * b, p0 * da + v0 * db, p0 * dda + v0 * ddb


def _quintic_weights(s, T: float) -> tuple:
    """The quintic's weights of ``p0`` and ``v0`` in position, velocity, acceleration at the fraction ``s`` of ``T``."""
    # p(s) = p0·(1 − 10s³ + 15s⁴ − 6s⁵) + v0·T·(s − 6s³ + 8s⁴ − 3s⁵)
    a = 1 - 10 * s**3 + 15 * s**4 - 6 * s**5
    da = (-30 * s**2 + 60 * s**3 - 30 * s**4) / T
    dda = (-60 * s + 180 * s**2 - 120 * s**3) / T**2
    b = T * (s - 6 * s**3 + 8 * s**4 - 3 * s**5)
    db = 1 - 18 * s**2 + 32 * s**3 - 15 * s**4
    ddb = (-36 * s + 96 * s**2 - 60 * s**3) / T
    return a, da, dda, b, db, ddb


MIN_BLEND_S = 0.2


@dataclass(frozen=True)
class Blend:
    """An offset from the trajectory (arm minus trajectory at the start) that fades out along a quintic over
    ``duration_s``, its acceleration within ``max_acceleration``: the arm is led back, never yanked."""

    start_s: float
    offset_position: np.ndarray
    offset_velocity: np.ndarray
    duration_s: float

    @classmethod
    def starting(
        cls, start_s: float, offset_position: np.ndarray, offset_velocity: np.ndarray, max_acceleration: float
    ) -> Blend:
        p0 = np.asarray(offset_position, dtype=float)
        v0 = np.asarray(offset_velocity, dtype=float)
        duration = MIN_BLEND_S
        probe = np.linspace(0.0, 1.0, 41)[:, None]  # fractions of the blend, one row each
        for _ in range(40):  # ×1.25 from 0.2 s: at most about a minute, always ends
            peak = float(np.max(np.abs(_quintic(p0, v0, duration, probe * duration)[2])))
            if peak <= max_acceleration:
                break
            duration *= 1.25
        return cls(start_s, p0, v0, duration)

    def offset_at(self, time_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return _quintic(self.offset_position, self.offset_velocity, self.duration_s, time_s - self.start_s)

    def done(self, time_s: float) -> bool:
        return time_s - self.start_s >= self.duration_s
