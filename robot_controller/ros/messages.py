"""Messages in and out, the shell's translation between ROS messages and the values blocks take
(``blocks.values``, where the checks on incoming data live), and time: ``builtin_interfaces/Time`` in seconds, a
node's clock in seconds."""

from __future__ import annotations

import importlib
from typing import Any

import numpy as np
from rclpy.node import Node
from sensor_msgs.msg import CameraInfo, CompressedImage, Image, JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension
from trajectory_msgs.msg import JointTrajectory

from robot_controller.blocks.values import (
    Array,
    CameraCalibration,
    CameraFrame,
    CompressedFrame,
    JointSample,
    WaypointRequest,
    labelled_correlation,
    labelled_position_std,
    position_std_label,
)

#: ``sensor_msgs/Image`` encodings a camera frame is taken in: (channels, whether they come reversed)
IMAGE_ENCODINGS = {"mono8": (1, False), "rgb8": (3, False), "bgr8": (3, True)}


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
        position_std = labelled_position_std(msg.header.frame_id) if msg.header.frame_id else None
        correlation = None
        if position_std is not None:
            correlation = labelled_correlation(msg.header.frame_id, position_std.size)
            if velocity.size == 0:  # a camera's: no velocity measured
                velocity = np.zeros_like(position)
        stamp_s = stamp_to_s(msg.header.stamp)
        return JointSample(stamp_s, list(msg.name), position, velocity, effort, position_std, correlation)
    if isinstance(msg, Image):
        return decode_image(msg)
    if isinstance(msg, CompressedImage):
        return CompressedFrame(stamp_to_s(msg.header.stamp), bytes(msg.data), msg.format, msg.header.frame_id)
    if isinstance(msg, CameraInfo):
        k = np.asarray(msg.k, dtype=float).reshape(3, 3)
        return CameraCalibration(stamp_to_s(msg.header.stamp), msg.width, msg.height, k, msg.header.frame_id)
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


def decode_image(msg: Image) -> CameraFrame | str:
    """An image as a frame, or why it cannot be used (an encoding other than 8-bit RGB or BGR, sizes that disagree)."""
    if msg.encoding not in IMAGE_ENCODINGS:
        return f"image encoding {msg.encoding!r}: expected one of {', '.join(IMAGE_ENCODINGS)}"
    expected = msg.height * msg.step
    if msg.width == 0 and msg.height == 0 and len(msg.data) == 0:  # no frame at this tick (blocks.camera)
        return CameraFrame(stamp_to_s(msg.header.stamp), np.zeros((0, 0), dtype=np.uint8), msg.header.frame_id)
    channels, reversed_ = IMAGE_ENCODINGS[msg.encoding]
    if msg.step < channels * msg.width or len(msg.data) != expected:
        return f"image {msg.width}×{msg.height}, step {msg.step}: {len(msg.data)} bytes, expected {expected}"
    rows = np.frombuffer(msg.data, dtype=np.uint8).reshape(msg.height, msg.step)[:, : channels * msg.width]
    pixels = rows if channels == 1 else rows.reshape(msg.height, msg.width, channels)
    if reversed_:
        pixels = pixels[:, :, ::-1]
    return CameraFrame(stamp_to_s(msg.header.stamp), pixels, msg.header.frame_id)


def _stamp(msg: Any, stamp_s: float) -> None:
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(round(stamp_s * 1e9), 1_000_000_000)


def encode(value: Any, msg: Any) -> Any:
    """``value`` written into ``msg`` (reused: a loop's message is built once)."""
    if isinstance(msg, JointState):
        _stamp(msg, value.stamp_s)
        msg.name = list(value.names)
        msg.position = value.position.tolist()
        if value.position_std is not None:  # a camera's: position alone, each with its σ
            msg.header.frame_id = position_std_label(value.position_std, value.position_correlation)
            msg.velocity = []
        else:
            msg.velocity = value.velocity.tolist()
        if value.effort is not None:
            msg.effort = value.effort.tolist()
    elif isinstance(msg, Image):
        _stamp(msg, value.stamp_s)
        msg.header.frame_id = value.frame_id
        msg.height, msg.width = value.pixels.shape[:2]
        channels = 1 if value.pixels.ndim == 2 else 3
        msg.encoding, msg.is_bigendian, msg.step = ("mono8" if channels == 1 else "rgb8"), 0, channels * msg.width
        msg.data = np.ascontiguousarray(value.pixels, dtype=np.uint8).tobytes()
    elif isinstance(msg, CompressedImage):
        _stamp(msg, value.stamp_s)
        msg.header.frame_id, msg.format, msg.data = value.frame_id, value.format, value.data
    elif isinstance(msg, CameraInfo):
        _stamp(msg, value.stamp_s)
        msg.header.frame_id = value.frame_id
        msg.width, msg.height = value.width_px, value.height_px
        msg.distortion_model, msg.d = "plumb_bob", [0.0] * 5
        msg.k = value.k.reshape(-1).tolist()
        msg.r = np.eye(3).reshape(-1).tolist()
        msg.p = np.hstack([value.k, np.zeros((3, 1))]).reshape(-1).tolist()
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
