"""A path through knots: piecewise quintic in time (position, velocity and acceleration continuous), held at
the last knot. Where a trajectory gives only positions, or no accelerations, :func:`knot_velocities` (Fritsch–Butland,
as in PCHIP: monotone between the points) and :func:`knot_accelerations` choose them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robot_controller.core.reference.trajectory import Sample


def _coefficients(duration_s: np.ndarray, p0, v0, a0, p1, v1, a1) -> np.ndarray:
    """The quintics ``c0 + c1·τ + … + c5·τ⁵`` from ``(p0, v0, a0)`` at τ = 0 to ``(p1, v1, a1)`` at
    ``duration_s``: shape ``(segments, 6, joints)`` for inputs of shape ``(segments, joints)``."""
    t = duration_s[:, None]
    h = p1 - p0
    c3 = (20 * h - (8 * v1 + 12 * v0) * t - (3 * a0 - a1) * t**2) / (2 * t**3)
    c4 = (-30 * h + (14 * v1 + 16 * v0) * t + (3 * a0 - 2 * a1) * t**2) / (2 * t**4)
    c5 = (12 * h - 6 * (v1 + v0) * t + (a1 - a0) * t**2) / (2 * t**5)
    return np.stack((p0, v0, 0.5 * a0, c3, c4, c5), axis=1)


@dataclass(frozen=True)
class QuinticPath:
    """Knots at ``times_s`` (strictly increasing, the first 0) joined by quintics; the
    last knot's position is held after it, at rest. Implements ``Trajectory``."""

    times_s: np.ndarray  #: (K,)
    coefficients: np.ndarray  #: (K-1, 6, joints)
    final_position: np.ndarray  #: (joints,)

    @classmethod
    def through(
        cls, times_s: np.ndarray, positions: np.ndarray, velocities: np.ndarray, accelerations: np.ndarray
    ) -> QuinticPath:
        """The path through ``K`` knots: arrays of shape ``(K,)`` and ``(K, joints)``."""
        times_s = np.asarray(times_s, dtype=float)
        p, v, a = (np.asarray(x, dtype=float) for x in (positions, velocities, accelerations))
        coefficients = _coefficients(np.diff(times_s), p[:-1], v[:-1], a[:-1], p[1:], v[1:], a[1:])
        return cls(times_s, coefficients, p[-1].copy())

    @property
    def duration_s(self) -> float:
        """When the last knot is reached (and held from then on), s."""
        return float(self.times_s[-1])

    def sample(self, t: float) -> Sample:
        p, v, a = self.sample_many(np.array([float(t)]))
        return p[0], v[0], a[0]

    def sample_many(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity, acceleration at each of ``t`` (shape ``(len(t), joints)`` each)."""
        t = np.asarray(t, dtype=float)
        n = self.final_position.size
        p = np.tile(self.final_position, (t.size, 1))
        v = np.zeros((t.size, n))
        a = np.zeros((t.size, n))
        moving = t < self.times_s[-1]
        if np.any(moving) and len(self.coefficients):
            tm = np.maximum(t[moving], 0.0)  # before the start: the first knot
            k = np.clip(np.searchsorted(self.times_s, tm, side="right") - 1, 0, len(self.coefficients) - 1)
            c = self.coefficients[k]  # (m, 6, n)
            tau = (tm - self.times_s[k])[:, None]
            p[moving] = c[:, 0] + tau * (c[:, 1] + tau * (c[:, 2] + tau * (c[:, 3] + tau * (c[:, 4] + tau * c[:, 5]))))
            v[moving] = c[:, 1] + tau * (2 * c[:, 2] + tau * (3 * c[:, 3] + tau * (4 * c[:, 4] + tau * 5 * c[:, 5])))
            a[moving] = 2 * c[:, 2] + tau * (6 * c[:, 3] + tau * (12 * c[:, 4] + tau * 20 * c[:, 5]))
        return p, v, a

    def sample_times(self, per_segment: int) -> np.ndarray:
        """``per_segment`` evenly spaced times in every segment, each knot included, and one
        after the end (the hold)."""
        if len(self.times_s) < 2:
            return np.zeros(1)
        fractions = np.linspace(0.0, 1.0, per_segment, endpoint=False)
        starts, lengths = self.times_s[:-1, None], np.diff(self.times_s)[:, None]
        inner = (starts + fractions * lengths).ravel()
        return np.concatenate((inner, [self.times_s[-1], self.times_s[-1] + 1.0]))


def knot_velocities(times_s: np.ndarray, positions: np.ndarray, first: np.ndarray) -> np.ndarray:
    """A velocity for every knot (shape of ``positions``): ``first`` at the first,
    Fritsch–Butland's harmonic mean of the slopes either side at the inner ones
    (0 where they differ in sign), 0 at the last."""
    velocities = np.zeros_like(positions, dtype=float)
    velocities[0] = first
    if len(times_s) > 2:
        h = np.diff(times_s)[:, None]
        slope = np.diff(positions, axis=0) / h
        left, right = slope[:-1], slope[1:]
        w_left, w_right = 2 * h[1:] + h[:-1], h[1:] + 2 * h[:-1]
        same_sign = left * right > 0
        with np.errstate(divide="ignore", invalid="ignore"):
            mean = (w_left + w_right) / (w_left / left + w_right / right)
        velocities[1:-1] = np.where(same_sign, mean, 0.0)
    return velocities


def knot_accelerations(times_s: np.ndarray, velocities: np.ndarray, first: np.ndarray) -> np.ndarray:
    """An acceleration for every knot: ``first`` at the first, the central difference of
    the velocities either side at the inner ones, 0 at the last."""
    accelerations = np.zeros_like(velocities, dtype=float)
    accelerations[0] = first
    if len(times_s) > 2:
        span = (times_s[2:] - times_s[:-2])[:, None]
        accelerations[1:-1] = (velocities[2:] - velocities[:-2]) / span
    return accelerations
