"""A joint trajectory's points and the path between them against the arm's limits: the quintics
may swing past a limit the points are within, so the path is sampled (``LIMIT_PER_SEGMENT`` per
segment) against each joint's position and velocity limits, and the torque the arm model needs
along it (at most ``TORQUE_SAMPLES`` inverse-dynamics calls, in the planner's executor) against
the limit less the feedback margin. Nothing is slowed: a user's timing is theirs.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robot_controller.core.model import JointLimits
from robot_controller.core.reference.quintic_path import QuinticPath

LIMIT_PER_SEGMENT = 256
TORQUE_SAMPLES = 2000
MIN_PER_SEGMENT = 4
MAX_PER_SEGMENT = 64
_EPS = 1e-9


def _num(value: float) -> str:
    return f"{value:.1f}" if abs(value) >= 0.995 else f"{value:.2f}"


def points_outside_limits(p: np.ndarray, v: np.ndarray | None, limits: JointLimits) -> str | None:
    """The first point with a position outside its joint's range or a velocity (``v``, if
    given) beyond its limit, in one line (None if every point is within them)."""
    for k, row in enumerate(p):
        for j, name in enumerate(limits.joint_names):
            if row[j] < limits.lower[j] - _EPS:
                return f"points[{k}]: {name} position {row[j]:g} rad is below its lower limit {limits.lower[j]:g} rad"
            if row[j] > limits.upper[j] + _EPS:
                return f"points[{k}]: {name} position {row[j]:g} rad is above its upper limit {limits.upper[j]:g} rad"
            if v is not None and abs(v[k, j]) > limits.velocity[j] + _EPS:
                return (
                    f"points[{k}]: {name} velocity {v[k, j]:g} rad/s is beyond its limit "
                    f"±{limits.velocity[j]:g} rad/s"
                )
    return None


def path_outside_limits(path: QuinticPath, limits: JointLimits) -> str | None:
    """Where the path goes furthest outside a joint's position range, or beyond its
    velocity limit, in one line (None if it never does)."""
    t = path.sample_times(LIMIT_PER_SEGMENT)
    p, v, _ = path.sample_many(t)
    checks = (
        (limits.lower - p, p, "rad, below its lower limit ", limits.lower, "rad"),
        (p - limits.upper, p, "rad, above its upper limit ", limits.upper, "rad"),
        (np.abs(v) - limits.velocity, v, "rad/s, beyond its velocity limit ±", limits.velocity, "rad/s"),
    )
    for excess, value, what, limit, unit in checks:
        if np.any(excess > _EPS):
            k, j = np.unravel_index(np.argmax(excess), excess.shape)  # where it is furthest out
            return (
                f"the path between the points reaches {value[k, j]:.4g} {what}{limit[j]:g} {unit} on "
                f"{limits.joint_names[j]} {t[k]:.2f} s in: add points or give them more time"
            )
    return None


def torque_shortfall(
    path: QuinticPath,
    dynamics,
    torque_limit_nm: np.ndarray,
    margin: float,
    joint_names: Sequence[str],
) -> tuple[np.ndarray, str | None]:
    """The largest |torque| per joint the arm model needs along the path (N·m), and, if
    it exceeds ``(1 - margin)`` of ``torque_limit_nm`` on some joint, a line naming
    the worst one with the numbers."""
    segments = max(1, len(path.times_s) - 1)
    per_segment = int(np.clip(TORQUE_SAMPLES // segments, MIN_PER_SEGMENT, MAX_PER_SEGMENT))
    t = path.sample_times(per_segment)
    q, v, a = path.sample_many(t)
    peak = np.zeros(q.shape[1])
    when = np.zeros(q.shape[1])
    for k in range(len(t)):
        torque = np.abs(dynamics.torque(q[k], v[k], a[k]))
        higher = torque > peak
        peak = np.where(higher, torque, peak)
        when = np.where(higher, t[k], when)
    limit = np.broadcast_to(np.asarray(torque_limit_nm, dtype=float), peak.shape)
    usable = limit * (1.0 - margin)
    if np.all(peak <= usable + _EPS):
        return peak, None
    j = int(np.argmax(peak / usable))
    return peak, (
        f"the trajectory needs {_num(peak[j])} N·m on {joint_names[j]} ({when[j]:.2f} s in) against "
        f"{_num(usable[j])} N·m usable ({_num(limit[j])} N·m limit, {margin * 100:.0f} % kept for feedback)"
    )
