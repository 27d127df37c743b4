"""What the ports carry, as plain values, and the checks a value from outside passes before any maths: each check
returns the clean arrays or a reason (a short sentence for a rate-limited warning)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np


# The values below are made several times a tick: plain slotted dataclasses, cheaper to make than frozen ones (whose
# fields are each set through ``object.__setattr__``). A value on a port is never written into, neither its fields
# nor its arrays: each reader may keep it as it is.
@dataclass(slots=True)
class JointSample:
    """The arm's joints at one instant: the true state, or a reading of it."""

    stamp_s: float  #: s, the instant it describes
    names: Sequence[str]
    position: np.ndarray  #: rad (m on a prismatic joint)
    velocity: np.ndarray  #: rad/s (m/s)
    effort: np.ndarray | None = None  #: N·m applied (N), if said
    #: rad (m), each position's σ where the sensor says it (a camera's: ``inf`` for a joint no marker constrains);
    #: None: the controller's own ``position_noise_std``. A reading that says it carries no velocity.
    position_std: np.ndarray | None = None
    #: (joints, joints) how the positions' errors go together, where the sensor says it (a camera's: joints whose
    #: axes are near parallel err together); None: independent
    position_correlation: np.ndarray | None = None


#: A reading's per-joint σ on the wire: a ``JointState`` has no field for it, so its ``header.frame_id`` says it,
#: ``position_std:<σ>,<σ>,…`` (rad, ``inf`` for none), then ``;correlation:`` and the correlations above the
#: diagonal row by row, as a command's tick is said in its layout's label.
POSITION_STD_PREFIX = "position_std:"
CORRELATION_PREFIX = ";correlation:"


def position_std_label(position_std: np.ndarray, correlation: np.ndarray | None = None) -> str:
    label = POSITION_STD_PREFIX + ",".join(f"{sigma:.6g}" for sigma in position_std.tolist())
    if correlation is not None and correlation.shape[0] > 1:
        above = correlation[np.triu_indices(correlation.shape[0], 1)]
        label += CORRELATION_PREFIX + ",".join(f"{r:.4f}" for r in above.tolist())
    return label


def labelled_position_std(label: str) -> np.ndarray | None:
    """The per-joint σ a reading's frame id says (None: it says none, or nothing readable; NaN or a negative σ is
    read as none for that joint: ``inf``)."""
    if not label.startswith(POSITION_STD_PREFIX):
        return None
    try:
        text = label[len(POSITION_STD_PREFIX) :].partition(CORRELATION_PREFIX)[0]
        sigmas = np.array([float(part) for part in text.split(",")])
    except ValueError:
        return None
    return np.where(sigmas >= 0, sigmas, np.inf)  # (NaN ≥ 0 is False)


def labelled_correlation(label: str, joint_count: int) -> np.ndarray | None:
    """The correlation matrix a reading's frame id says, or None (none said, or not one that can be: each within
    [-1, 1] and the whole positive semi-definite)."""
    _, found, text = label.partition(CORRELATION_PREFIX)
    if not found or joint_count < 2:
        return None
    try:
        above = np.array([float(part) for part in text.split(",")])
    except ValueError:
        return None
    upper = np.triu_indices(joint_count, 1)
    if above.size != upper[0].size or not all_finite(above) or np.any(np.abs(above) > 1.0):
        return None
    correlation = np.eye(joint_count)
    correlation[upper] = above
    correlation.T[upper] = above
    if np.linalg.eigvalsh(correlation)[0] < -1e-3:
        return None
    return correlation


@dataclass(slots=True)
class CameraFrame:
    """One camera image: ``pixels`` (height, width) mono or (height, width, 3) RGB, 8 bits, exposed at ``stamp_s``."""

    stamp_s: float
    pixels: np.ndarray
    frame_id: str = "camera"


@dataclass(slots=True)
class CompressedFrame:
    """An image compressed (``format``: ``jpeg``), for the view and the bag."""

    stamp_s: float
    data: bytes
    format: str = "jpeg"
    frame_id: str = "camera"


@dataclass(slots=True)
class CameraCalibration:
    """A camera's intrinsics as ``CameraInfo`` says them: the image size and the 3 × 3 matrix K (pixels)."""

    stamp_s: float
    width_px: int
    height_px: int
    k: np.ndarray
    frame_id: str = "camera"


def all_finite(values: np.ndarray) -> bool:
    """``np.isfinite(values).all()``, on Python's floats: for the few values a port carries (one per joint, each
    tick) cheaper than a numpy reduction."""
    return all(map(math.isfinite, values.ravel().tolist()))


def check_joint_state(
    names: Sequence[str], position: Sequence[float], velocity: Sequence[float], expected_names: Sequence[str]
) -> tuple[np.ndarray, np.ndarray] | str:
    """``position`` and ``velocity`` as float arrays in the order of ``expected_names`` (the arm's joints), or the
    reason they cannot be used. Without names (as the tutorial's sensor sends them), one value per joint in the arm's
    order. Arrays in that order already are returned as they are, not copied: a port's value is never written into."""
    n = len(expected_names)
    position = np.asarray(position, dtype=float)
    velocity = np.asarray(velocity, dtype=float)
    if position.size == 0:
        return "empty position array"
    if len(names) == 0:
        if position.size != n or velocity.size != n:
            return f"expected {n} position and velocity values, got {position.size} and {velocity.size}"
    elif len(names) != position.size or len(names) != velocity.size:
        return f"name, position and velocity lengths differ ({len(names)}, {position.size}, {velocity.size})"
    elif not (names is expected_names or list(names) == list(expected_names)):  # (a well-configured graph's are)
        index = {name: k for k, name in enumerate(names)}
        unknown = [name for name in names if name not in expected_names]
        if unknown:
            return f"unknown joint name(s) {unknown}, expected {list(expected_names)}"
        missing = [name for name in expected_names if name not in index]
        if missing:
            return f"missing joint(s) {missing}"
        order = [index[name] for name in expected_names]
        position, velocity = position[order], velocity[order]
    if not (all_finite(position) and all_finite(velocity)):
        return "non-finite position or velocity"
    return position, velocity


TrajectorySample = tuple[np.ndarray, np.ndarray, np.ndarray, float | None]


def check_trajectory(data: Sequence[float], joint_count: int) -> TrajectorySample | str:
    """A reference array as ``(p, v, a, sample_time_s or None)``, or the reason it cannot be used: ``[p…, v…, a…]``
    (one value per joint each), the same followed by the sample time in s (our planner's), or the tutorial's
    ``[p…, v…]``."""
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
    if not all_finite(data) or (sample_time is not None and not math.isfinite(sample_time)):
        return "non-finite value in trajectory"
    return p, v, a, sample_time


def check_effort(data: Sequence[float], joint_count: int) -> np.ndarray | str:
    data = np.asarray(data, dtype=float)
    if data.size != joint_count:
        return f"expected {joint_count} torque value(s), got {data.size}"
    if not all_finite(data):
        return "non-finite torque"
    return data


@dataclass(slots=True)
class Array:
    """A flat array with the label of its first dimension (where our messages say what they carry beyond the
    numbers: a command's tick, the brakes' reasons); a table's ``row`` (its label and size) as the second dimension.
    The label is what goes on the wire; the tick it says, if any, is kept beside it as a number (``tick_s``), read
    from the label once when the array is made (:func:`at_tick` gives both, reading nothing)."""

    data: np.ndarray
    label: str = ""
    row: tuple[str, int] | None = None
    tick_s: float | None = None  #: s, the tick the label says (None: it says none)

    def __post_init__(self) -> None:
        if self.tick_s is None and self.label:
            self.tick_s = labelled_tick_s(self.label)


#: A command's label: the tick it was computed for, ``tick_ns:<ns of the loop's clock>`` (a ``Float64MultiArray``
#: has no header; the tutorial's nodes ignore the layout).
TICK_LABEL_PREFIX = "tick_ns:"


def tick_label(tick_s: float) -> str:
    return f"{TICK_LABEL_PREFIX}{round(tick_s * 1e9)}"


def at_tick(data: np.ndarray, tick_s: float) -> Array:
    """``data`` labelled with the tick (s) it was computed for (a command)."""
    return Array(data, tick_label(tick_s), None, tick_s)


def labelled_tick_s(label: str) -> float | None:
    """The tick (s) a label says, or None if it says none."""
    if not label.startswith(TICK_LABEL_PREFIX):
        return None
    try:
        return int(label[len(TICK_LABEL_PREFIX) :]) * 1e-9
    except ValueError:
        return None


#: The brakes' label: ``engaged:`` and why they hold, comma-separated (``start``, ``drive_timeout``, ``requested``,
#: ``estop``; nothing when released).
BRAKES_LABEL_PREFIX = "engaged:"


def brakes_label(reasons: set[str]) -> str:
    return BRAKES_LABEL_PREFIX + ",".join(sorted(reasons))


def brake_reasons(label: str) -> set[str] | None:
    """Why the brakes hold, as their label says (None: it does not say)."""
    if not label.startswith(BRAKES_LABEL_PREFIX):
        return None
    return set(filter(None, label[len(BRAKES_LABEL_PREFIX) :].split(",")))


@dataclass(frozen=True)
class WaypointRequest:
    """A ``JointTrajectory`` as the planner takes it: joints, then per point its time and values (empty rows where a
    point gives none)."""

    stamp_s: float  #: s, its header's stamp (0: start on receipt)
    joint_names: tuple[str, ...]
    times_s: tuple[float, ...]  #: s from its time 0, per point
    positions: tuple[tuple[float, ...], ...]
    velocities: tuple[tuple[float, ...], ...] = ()
    accelerations: tuple[tuple[float, ...], ...] = ()
