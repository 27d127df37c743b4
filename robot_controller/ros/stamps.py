"""Time in messages: ``builtin_interfaces/Time`` to and from seconds, and the tick a ``/joint_commands``
message was computed for, in its first dimension's label ``tick_ns:<ROS time in ns>``
(``Float64MultiArray`` has no header; the tutorial's nodes ignore the layout).
"""

from __future__ import annotations

from typing import Any

from rclpy.time import Time
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

LABEL_PREFIX = "tick_ns:"


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
