"""The tick a ``/joint_commands`` message was computed for, carried in its layout.

``std_msgs/Float64MultiArray`` has no header, and the tutorial's nodes speak it
unchanged, so the stamp rides in the one free-text field it has: the first
dimension's label, ``tick_ns:<ROS time in ns>``. A drive that knows it (our
``motor_node``) drops a command that reaches it too late to be of use, the way a
fieldbus drive's watchdog refuses a stale set-point, and in lockstep takes it
for the command's time; one that does not (the tutorial's) ignores the layout.
A command without it is taken as it comes.
"""

from __future__ import annotations

from std_msgs.msg import Float64MultiArray, MultiArrayDimension

LABEL_PREFIX = "tick_ns:"


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
