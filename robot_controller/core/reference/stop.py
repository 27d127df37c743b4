"""Bringing a moving reference to rest within a deceleration: a cancelled goal's controlled stop, and the stop a new
trajectory makes first when joining it directly would overshoot its first point. One quintic to rest at
``p0 + v0·T/2 + a0·T²/20``: its deceleration peaks at ``1.875·|v0|/T``, so ``T`` follows from the deceleration
allowed; a stop that would rest beyond the joints' range is made harder instead (the range is the arm's, the
deceleration a preference).
"""

from __future__ import annotations

import numpy as np

from robot_controller.core.reference.quintic_path import QuinticPath
from robot_controller.core.reference.trajectory import Sample

MIN_STOP_S = 0.05  #: even a reference nearly at rest settles over this long (s)
_PEAK_DECELERATION_PER_V0_T = 1.875  # of a quintic from v0 to rest over T with the end above
# A quintic of this shape from (v0, a0) against v0 keeps its velocity's sign while |a0|·T <= (4 + 2√3)·|v0| (7.46).
_ONE_WAY = 7.0
_BISECTIONS = 40
_SHORTEST_STOP_S = 1e-3  #: a reference at its limit at speed stops this fast (the drive's own limit then rules)


def stop_time_s(velocity: np.ndarray, acceleration: np.ndarray, deceleration: float) -> float:
    """How long the stop from ``velocity`` (and ``acceleration``) takes at ``deceleration`` (rad/s²) at most, s."""
    speed = float(np.max(np.abs(velocity), initial=0.0))
    pull = float(np.max(np.abs(acceleration), initial=0.0))
    return max(MIN_STOP_S, _PEAK_DECELERATION_PER_V0_T * speed / deceleration + pull / deceleration)


def rest_position(start: Sample, duration_s: float) -> np.ndarray:
    """Where the stop from ``start`` over ``duration_s`` comes to rest."""
    p0, v0, a0 = (np.asarray(x, dtype=float) for x in start)
    return p0 + v0 * duration_s / 2 + a0 * duration_s**2 / 20


def stop_path(
    start: Sample, deceleration: float, position_range: tuple[np.ndarray, np.ndarray] | None = None
) -> QuinticPath:
    """The reference from ``start`` to rest within ``deceleration`` (rad/s²), then held, never turning back (a joint
    already slowing keeps only the part of its acceleration that cannot reverse it); a stop that would rest beyond
    ``position_range`` (lower, upper per joint) is shortened to rest within it."""
    p0, v0, a0 = (np.asarray(x, dtype=float) for x in start)
    duration = stop_time_s(v0, a0, deceleration)
    slowing = a0 * v0 <= 0.0
    a0 = np.where(slowing, np.clip(a0, -_ONE_WAY * np.abs(v0) / duration, _ONE_WAY * np.abs(v0) / duration), a0)
    # A smaller acceleration shortens the stop, and a shorter stop allows more: the bound still holds.
    duration = stop_time_s(v0, a0, deceleration)
    start = (p0, v0, a0)
    if position_range is not None:
        duration = _within(start, duration, *position_range)
    rest = np.zeros_like(p0)
    return QuinticPath.through(
        np.array([0.0, duration]),
        np.vstack((p0, rest_position(start, duration))),
        np.vstack((v0, rest)),
        np.vstack((a0, rest)),
    )


def _within(start: Sample, duration_s: float, lower: np.ndarray, upper: np.ndarray) -> float:
    """The longest stop no longer than ``duration_s`` whose rest is within [lower, upper], by bisection."""

    def inside(duration: float) -> bool:
        rest = rest_position(start, duration)
        return bool(np.all(rest >= np.minimum(lower, start[0])) and np.all(rest <= np.maximum(upper, start[0])))

    if inside(duration_s):
        return duration_s
    short, long = 0.0, duration_s
    for _ in range(_BISECTIONS):
        middle = 0.5 * (short + long)
        short, long = (middle, long) if inside(middle) else (short, middle)
    return max(short, _SHORTEST_STOP_S)


def overshoots(path: QuinticPath, start: Sample, deceleration: float, samples: int = 64) -> bool:
    """Whether ``path``'s first segment goes past both its first knot's target and where a stop from ``start`` at
    ``deceleration`` would rest, on some joint (a join that swings beyond the goal)."""
    if len(path.times_s) < 2:
        return False
    p0, v0, a0 = (np.asarray(x, dtype=float) for x in start)
    end_s = float(path.times_s[1])
    target = path.sample(end_s)[0]
    natural = rest_position(start, stop_time_s(v0, a0, deceleration))
    low = np.minimum.reduce([p0, target, natural])
    high = np.maximum.reduce([p0, target, natural])
    positions, _, _ = path.sample_many(np.linspace(0.0, end_s, samples))
    slack = 1e-6 + 1e-3 * np.abs(high - low)
    return bool(np.any(positions < low - slack) or np.any(positions > high + slack))
