"""``builtin_interfaces/Time`` to and from seconds."""

from __future__ import annotations

from typing import Any

from rclpy.time import Time


def stamp_to_s(stamp: Any) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def s_to_stamp(time_s: float) -> Any:
    """A ``builtin_interfaces/Time`` for ``time_s`` seconds (to the nearest ns)."""
    return Time(nanoseconds=round(time_s * 1e9)).to_msg()
