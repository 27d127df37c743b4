"""Layout of ``/controller/state`` (a labelled ``std_msgs/Float64MultiArray``).

``data`` is ``[time_s, status_code, measurement_stamp_s]`` followed by one block per field, each
``joint_count`` long, in :data:`FIELDS` order. The message's layout carries
the same labels (one dimension per block), so ``ros2 topic echo`` shows what
each number is. This module only builds and reads the flat array.
"""

from __future__ import annotations

import numpy as np

HEADER = ("time_s", "status", "measurement_stamp_s")
FIELDS = ("reference", "measured", "error", "p", "i", "d", "feedforward", "command", "saturated")
STATUS_CODES = {
    "ok": 0,
    "holding": 1,
    "no_measurement": 2,
    "watchdog": 3,
    "sensor_lost": 4,
    "reacquiring": 5,
    "reference_lost": 6,
    "stopped": 7,
    "law_fault": 8,
    "law_stopped": 9,
}


def encode(
    time_s: float, status: str, measurement_stamp_s: float, joint_count: int, values: dict[str, np.ndarray]
) -> list[float]:
    out = [float(time_s), float(STATUS_CODES[status]), float(measurement_stamp_s)]
    shape = (joint_count,)
    for name in FIELDS:
        value = values[name]
        if isinstance(value, np.ndarray) and value.shape == shape:
            # One value per joint already (every tick's case): its floats as they are,
            # without broadcast_to's view, which costs more than the copy for a few joints.
            out.extend((value if value.dtype == np.float64 else value.astype(float)).tolist())
        else:
            out.extend(np.broadcast_to(np.asarray(value, dtype=float), shape).tolist())
    return out


def decode(data: np.ndarray, joint_count: int) -> dict[str, np.ndarray]:
    """Inverse of :func:`encode` for one message, or for rows of many (shape ``(m, size)``)."""
    data = np.asarray(data, dtype=float)
    expected = len(HEADER) + len(FIELDS) * joint_count
    if data.shape[-1] != expected:
        raise ValueError(
            f"controller state: expected {expected} values for {joint_count} joint(s), got {data.shape[-1]}"
        )
    out = {name: data[..., k] for k, name in enumerate(HEADER)}
    for k, name in enumerate(FIELDS):
        start = len(HEADER) + k * joint_count
        out[name] = data[..., start : start + joint_count]
    return out


def width(joint_count: int) -> int:
    """Values in one ``/controller/state`` message for ``joint_count`` joints."""
    return len(HEADER) + len(FIELDS) * joint_count


def joint_count_of(size: int) -> int:
    n, rem = divmod(size - len(HEADER), len(FIELDS))
    if rem or n < 1:
        raise ValueError(f"controller state: {size} values is not a valid layout")
    return n
