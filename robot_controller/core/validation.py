"""Checks on incoming data, before any maths. Each returns the clean arrays
or a reason (a short sentence for a rate-limited warning)."""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

Checked = tuple[np.ndarray, np.ndarray] | str


def check_joint_state(
    names: Sequence[str], position: Sequence[float], velocity: Sequence[float], expected_names: Sequence[str]
) -> Checked:
    """Validate a JointState against the arm's joints; reorder by name.

    Messages without names are accepted when their arrays have exactly one
    entry per joint (in the arm's order), as the tutorial's sensor sends them
    named; unknown or missing names are refused.
    """
    n = len(expected_names)
    position = np.asarray(position, dtype=float)
    velocity = np.asarray(velocity, dtype=float)
    if position.size == 0:
        return "empty position array"
    if len(names) == 0:
        if position.size != n or velocity.size != n:
            return f"expected {n} position and velocity values, got {position.size} and {velocity.size}"
        order = np.arange(n)
    else:
        if len(names) != position.size or len(names) != velocity.size:
            return (f"name, position and velocity lengths differ "
                    f"({len(names)}, {position.size}, {velocity.size})")
        index = {name: k for k, name in enumerate(names)}
        unknown = [name for name in names if name not in expected_names]
        if unknown:
            return f"unknown joint name(s) {unknown}, expected {list(expected_names)}"
        missing = [name for name in expected_names if name not in index]
        if missing:
            return f"missing joint(s) {missing}"
        order = np.array([index[name] for name in expected_names])
    position, velocity = position[order], velocity[order]
    if not (np.all(np.isfinite(position)) and np.all(np.isfinite(velocity))):
        return "non-finite position or velocity"
    return position, velocity


def check_trajectory(data: Sequence[float], joint_count: int) -> tuple[np.ndarray, np.ndarray, np.ndarray] | str:
    """Validate a ``/trajectory`` array: ``[p, v, a]`` per joint, or the tutorial's ``[p, v]``.

    Layout: all positions, then all velocities, then all accelerations.
    """
    data = np.asarray(data, dtype=float)
    if data.size == 3 * joint_count:
        p, v, a = data[:joint_count], data[joint_count:2 * joint_count], data[2 * joint_count:]
    elif data.size == 2 * joint_count:
        p, v = data[:joint_count], data[joint_count:]
        a = np.zeros(joint_count)
    else:
        return f"expected {3 * joint_count} values ([position, velocity, acceleration] per joint), got {data.size}"
    if not np.all(np.isfinite(data)):
        return "non-finite value in trajectory"
    return p, v, a


def check_effort(data: Sequence[float], joint_count: int) -> np.ndarray | str:
    data = np.asarray(data, dtype=float)
    if data.size != joint_count:
        return f"expected {joint_count} torque value(s), got {data.size}"
    if not np.all(np.isfinite(data)):
        return "non-finite torque"
    return data
