"""Messages in and out, the shell's translation between ROS messages and the values blocks take
(``blocks.values``, where the checks on incoming data live), and time: ``builtin_interfaces/Time`` in seconds, a
node's clock in seconds."""

from __future__ import annotations

import importlib
from typing import Any

import numpy as np
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension
from trajectory_msgs.msg import JointTrajectory

from robot_controller.blocks.values import Array, JointSample, WaypointRequest


def stamp_to_s(stamp: Any) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def clock_s(node: Node) -> float:
    """``node``'s clock (ROS time: simulated under ``use_sim_time``) in seconds, without building a ``Time``."""
    handle = node.get_clock().handle
    with handle:
        return handle.get_now().nanoseconds * 1e-9


def message_class(msg_type: str) -> Any:
    """The message class of a ROS type name, ``package/msg/Name``."""
    package, _, name = msg_type.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


def decode(msg: Any) -> Any:
    """A message as the value a block takes (``blocks.values``): joint states as a ``JointSample``, arrays as an
    ``Array`` with their first dimension's label, a joint trajectory as a ``WaypointRequest``, a flag as a bool, a
    text as a str."""
    if isinstance(msg, JointState):
        effort = np.asarray(msg.effort, dtype=float) if len(msg.effort) else None
        position, velocity = np.asarray(msg.position, dtype=float), np.asarray(msg.velocity, dtype=float)
        return JointSample(stamp_to_s(msg.header.stamp), list(msg.name), position, velocity, effort)
    if isinstance(msg, Float64MultiArray):
        return Array(np.asarray(msg.data, dtype=float), msg.layout.dim[0].label if msg.layout.dim else "")
    if isinstance(msg, JointTrajectory):
        points = msg.points
        return WaypointRequest(
            stamp_to_s(msg.header.stamp),
            tuple(msg.joint_names),
            tuple(p.time_from_start.sec + p.time_from_start.nanosec * 1e-9 for p in points),
            tuple(tuple(p.positions) for p in points),
            tuple(tuple(p.velocities) for p in points),
            tuple(tuple(p.accelerations) for p in points),
        )
    return msg.data  # Bool, String


def encode(value: Any, msg: Any) -> Any:
    """``value`` written into ``msg`` (reused: a loop's message is built once)."""
    if isinstance(msg, JointState):
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(round(value.stamp_s * 1e9), 1_000_000_000)
        msg.name = list(value.names)
        msg.position = value.position.tolist()
        msg.velocity = value.velocity.tolist()
        if value.effort is not None:
            msg.effort = value.effort.tolist()
    elif isinstance(msg, Float64MultiArray):
        msg.data = value.data.tolist()
        size = len(msg.data)
        if value.row is not None:
            label, row_size = value.row
            msg.layout.dim = [
                MultiArrayDimension(label=value.label, size=size // row_size, stride=size),
                MultiArrayDimension(label=label, size=row_size, stride=row_size),
            ]
        elif value.label:
            msg.layout.dim = [MultiArrayDimension(label=value.label, size=size, stride=size)]
        else:
            msg.layout.dim = []
    else:
        msg.data = value
    return msg
