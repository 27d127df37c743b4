"""Messages in and out, the shell's translation between ROS messages and arrays: checks on
incoming data before any maths (each returns the clean arrays or a reason, a short sentence for a
rate-limited warning), and time: ``builtin_interfaces/Time`` to and from seconds, a node's clock
in seconds, and the tick a ``/joint_commands`` message was computed for, in its first dimension's
label ``tick_ns:<ROS time in ns>`` (``Float64MultiArray`` has no header; the tutorial's nodes
ignore the layout).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from rclpy.node import Node
from rclpy.time import Time
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

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
    if len(names) == n and position.size == n and velocity.size == n and list(names) == list(expected_names):
        # Every reading of a well-configured graph: already in the arm's order (copies, as the reorder gives).
        if not (np.isfinite(position).all() and np.isfinite(velocity).all()):
            return "non-finite position or velocity"
        return position.copy(), velocity.copy()
    if len(names) == 0:
        if position.size != n or velocity.size != n:
            return f"expected {n} position and velocity values, got {position.size} and {velocity.size}"
        order = np.arange(n)
    else:
        if len(names) != position.size or len(names) != velocity.size:
            return f"name, position and velocity lengths differ " f"({len(names)}, {position.size}, {velocity.size})"
        index = {name: k for k, name in enumerate(names)}
        unknown = [name for name in names if name not in expected_names]
        if unknown:
            return f"unknown joint name(s) {unknown}, expected {list(expected_names)}"
        missing = [name for name in expected_names if name not in index]
        if missing:
            return f"missing joint(s) {missing}"
        order = np.array([index[name] for name in expected_names])
    position, velocity = position[order], velocity[order]
    if not (np.isfinite(position).all() and np.isfinite(velocity).all()):
        return "non-finite position or velocity"
    return position, velocity


TrajectorySample = tuple[np.ndarray, np.ndarray, np.ndarray, float | None]


def check_trajectory(data: Sequence[float], joint_count: int) -> TrajectorySample | str:
    """Validate a ``/trajectory`` array into ``(p, v, a, sample_time_s or None)``.

    Accepted: ``[p…, v…, a…]`` (one block per quantity, one value per
    joint); the same followed by the sample time in seconds (our planner,
    so the controller knows when the sample was taken); or the tutorial's
    ``[p…, v…]``.
    """
    data = np.asarray(data, dtype=float)
    n = joint_count
    sample_time: float | None = None
    if data.size == 3 * n + 1:
        sample_time = float(data[-1])
        data = data[:-1]
    if data.size == 3 * n:
        p, v, a = data[:n], data[n : 2 * n], data[2 * n :]
    elif data.size == 2 * n:
        p, v = data[:n], data[n:]
        a = np.zeros(n)
    else:
        return (
            f"expected {3 * n} values ([position, velocity, acceleration] per joint) "
            f"or {3 * n + 1} (with the sample time), got {np.asarray(data).size + (sample_time is not None)}"
        )
    if not np.isfinite(data).all() or (sample_time is not None and not math.isfinite(sample_time)):
        return "non-finite value in trajectory"
    return p, v, a, sample_time


def check_effort(data: Sequence[float], joint_count: int) -> np.ndarray | str:
    data = np.asarray(data, dtype=float)
    if data.size != joint_count:
        return f"expected {joint_count} torque value(s), got {data.size}"
    if not np.isfinite(data).all():
        return "non-finite torque"
    return data


# --- time ---------------------------------------------------------------------------

LABEL_PREFIX = "tick_ns:"


#: ``/sim/brakes``' label: ``engaged:`` and why they hold, comma-separated (``start``, ``drive_timeout``,
#: ``requested``, ``estop``; nothing when released).
BRAKES_LABEL_PREFIX = "engaged:"


def brakes_label(reasons: set[str]) -> str:
    return BRAKES_LABEL_PREFIX + ",".join(sorted(reasons))


def brake_reasons(msg: Float64MultiArray) -> set[str] | None:
    """Why ``msg``'s brakes hold, as its label says (None: it does not say)."""
    if not msg.layout.dim or not msg.layout.dim[0].label.startswith(BRAKES_LABEL_PREFIX):
        return None
    said = msg.layout.dim[0].label[len(BRAKES_LABEL_PREFIX) :]
    return set(said.split(",")) if said else set()


def stamp_to_s(stamp: Any) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def s_to_stamp(time_s: float) -> Any:
    """A ``builtin_interfaces/Time`` for ``time_s`` seconds (to the nearest ns)."""
    return Time(nanoseconds=round(time_s * 1e9)).to_msg()


def stamp_command(msg: Float64MultiArray, tick_s: float) -> None:
    """Mark ``msg`` (its ``data`` already set) as computed for the tick at ``tick_s`` (ROS time, s)."""
    size = len(msg.data)
    label = f"{LABEL_PREFIX}{round(tick_s * 1e9)}"
    if msg.layout.dim:
        dim = msg.layout.dim[0]
        dim.label, dim.size, dim.stride = label, size, size
    else:
        msg.layout.dim = [MultiArrayDimension(label=label, size=size, stride=size)]


def command_tick_s(msg: Float64MultiArray) -> float | None:
    """The tick (ROS time, s) ``msg`` says it was computed for, or None if it does not say."""
    if not msg.layout.dim:
        return None
    label = msg.layout.dim[0].label
    if not label.startswith(LABEL_PREFIX):
        return None
    try:
        return int(label[len(LABEL_PREFIX) :]) * 1e-9
    except ValueError:
        return None


def clock_s(node: Node) -> float:
    """``node``'s clock (ROS time: simulated under ``use_sim_time``) in seconds, without building a ``Time``."""
    handle = node.get_clock().handle
    with handle:
        return handle.get_now().nanoseconds * 1e-9
