"""Layout of the controller's state (port ``state``, a labelled ``std_msgs/Float64MultiArray``): ``[time_s, status_code,
measurement_stamp_s]``, then one block of ``joint_count`` per :data:`FIELDS` entry, then a law's own ``state_terms``
blocks and, with the inertia adaptation, :data:`ADAPTED_ARMATURE`'s; the layout's labels name each block, so
``ros2 topic echo`` shows what each number is. A reader that knows only the standard blocks takes the first
:func:`width` values (:func:`standard`); :func:`extra` reads the rest."""

from __future__ import annotations

from collections.abc import Sequence
from itertools import chain

import numpy as np

from robot_controller.core.controller.supervision import Status

HEADER = ("time_s", "status", "measurement_stamp_s")
FIELDS = ("reference", "measured", "error", "p", "i", "d", "feedforward", "command", "saturated")
#: the extra block, after a law's own, of the armature the inertia adaptation has learnt (kg·m² per joint), when on
ADAPTED_ARMATURE = "adapted_armature_kgm2"
STATUS_CODES = {status.value: code for code, status in enumerate(Status)}


def encode(
    time_s: float,
    status: str,
    measurement_stamp_s: float,
    joint_count: int,
    values: dict[str, np.ndarray],
    extra: Sequence[np.ndarray] = (),
) -> list[float]:
    """The flat array: the header, the :data:`FIELDS` blocks from ``values``, then the ``extra`` blocks (a law's)."""
    out = [float(time_s), float(STATUS_CODES[status]), float(measurement_stamp_s)]
    shape = (joint_count,)
    for value in chain(map(values.__getitem__, FIELDS), extra):
        if isinstance(value, np.ndarray) and value.shape == shape:
            # One value per joint already (every tick's case): as it is (broadcast_to costs more than a copy).
            out.extend((value if value.dtype == np.float64 else value.astype(float)).tolist())
        else:
            out.extend(np.broadcast_to(np.asarray(value, dtype=float), shape).tolist())
    return out


def decode(data: np.ndarray, joint_count: int) -> dict[str, np.ndarray]:
    """Inverse of :func:`encode` for one message, or for rows of many (shape ``(m, size)``)."""
    data = np.asarray(data, dtype=float)
    expected = width(joint_count)
    if not fits(data.shape[-1], joint_count):
        raise ValueError(
            f"controller state: expected {expected} values for {joint_count} joint(s), got {data.shape[-1]}"
        )
    data = data[..., :expected]  # a law's extra blocks after the standard ones: see extra()
    out = {name: data[..., k] for k, name in enumerate(HEADER)}
    for k, name in enumerate(FIELDS):
        start = len(HEADER) + k * joint_count
        out[name] = data[..., start : start + joint_count]
    return out


def width(joint_count: int) -> int:
    """Values in one state message for ``joint_count`` joints."""
    return len(HEADER) + len(FIELDS) * joint_count


def fits(size: int, joint_count: int) -> bool:
    """Whether ``size`` values are a message of this layout: the standard blocks, then any whole extra blocks."""
    extra = size - width(joint_count)
    return extra >= 0 and extra % joint_count == 0


def standard(data: Sequence[float], joint_count: int) -> Sequence[float] | None:
    """The header and standard blocks of one message (its first :func:`width` values), or None if it does not fit."""
    return data[: width(joint_count)] if fits(len(data), joint_count) else None


def extra(data: Sequence[float], joint_count: int, names: Sequence[str]) -> dict[str, np.ndarray]:
    """A message's extra blocks by name (the layout's labels after the standard ones); empty if they do not match."""
    rest = np.asarray(data[width(joint_count) :], dtype=float)
    if not names or rest.size != len(names) * joint_count:
        return {}
    return {name: rest[k * joint_count : (k + 1) * joint_count] for k, name in enumerate(names)}
