"""Metrics of docs/design.md §7, as functions on arrays: they score a live run,
an in-process simulation or a recording read back from a bag alike."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

WARMUP_S = 2.0


# Samples of the true state further apart than this many typical spacings leave a gap.
GAP_PERIODS = 5


def true_position_at(
    times_s: np.ndarray, true_time_s: np.ndarray, true_position: np.ndarray, true_velocity: np.ndarray | None = None
) -> np.ndarray:
    """The true joint position at ``times_s``, ``(len(times_s), n)``: a cubic Hermite spline with velocities, else
    linear; NaN across a gap of more than ``GAP_PERIODS`` typical spacings (the simulator was not running: what
    the arm did there is unknown, not a curve to invent)."""
    true_time_s = np.asarray(true_time_s, dtype=float)
    true_position = np.asarray(true_position, dtype=float).reshape(len(true_time_s), -1)
    order = np.argsort(true_time_s, kind="stable")
    t, q = true_time_s[order], true_position[order]
    keep = np.concatenate(([True], np.diff(t) > 0))
    t, q = t[keep], q[keep]
    times_s = np.asarray(times_s, dtype=float)
    if true_velocity is not None and len(t) >= 2:
        v = np.asarray(true_velocity, dtype=float).reshape(len(true_time_s), -1)[order][keep]
        from scipy.interpolate import CubicHermiteSpline  # here: the controller node imports this module too

        out = CubicHermiteSpline(t, q, v, axis=0, extrapolate=False)(times_s)
    else:
        out = np.column_stack([np.interp(times_s, t, q[:, j], left=np.nan, right=np.nan) for j in range(q.shape[1])])
    if len(t) >= 2:
        spacing = np.diff(t)
        after = np.clip(np.searchsorted(t, times_s, side="right"), 1, len(t) - 1)
        in_gap = spacing[after - 1] > GAP_PERIODS * np.median(spacing)
        out[in_gap] = np.nan
    return out


def tracking_metrics(
    tick_time_s: np.ndarray,
    reference_position: np.ndarray,
    true_position_at_tick: np.ndarray,
    measured_position: np.ndarray,
    *,
    warmup_s: float = WARMUP_S,
    units: list[str] | None = None,
) -> dict[str, Any]:
    """Tracking errors after ``warmup_s`` from the first tick, and the largest before it (``start_tracking_max_*``,
    which a verdict judges too): ``tracking_*`` against the TRUE position at each tick, ``measured_rms_*`` against
    what the sensor said, per joint and the worst joint's (:func:`joint_errors`)."""
    t = np.asarray(tick_time_s, dtype=float)
    ref = np.asarray(reference_position, dtype=float).reshape(len(t), -1)
    true = np.asarray(true_position_at_tick, dtype=float).reshape(len(t), -1)
    meas = np.asarray(measured_position, dtype=float).reshape(len(t), -1)
    window = (t >= t[0] + warmup_s) if len(t) else np.zeros(0, bool)
    window &= np.all(np.isfinite(true), axis=1)
    if not np.any(window):
        raise ValueError(f"no control ticks after the {warmup_s} s warm-up to score")
    measured = joint_errors(ref[window] - meas[window], "measured", units)
    start = (t < t[0] + warmup_s) & np.all(np.isfinite(true), axis=1)
    start_errors = joint_errors(ref[start] - true[start], "start_tracking", units) if np.any(start) else {}
    return {
        **joint_errors(ref[window] - true[window], units=units),
        **{key: value for key, value in start_errors.items() if "_max" in key},
        **{key: value for key, value in measured.items() if key.startswith("measured_rms")},
        "scored_ticks": int(np.count_nonzero(window)),
    }


def joint_errors(error: np.ndarray, prefix: str = "tracking", units: list[str] | None = None) -> dict[str, Any]:
    """RMS and largest |error| (rows: samples, columns: joints) of each joint (``{prefix}_rms_per_joint``,
    ``{prefix}_max_per_joint``) and the worst joint's of each unit (``units``: ``"rad"`` or ``"m"`` per joint,
    default all ``"rad"``; :func:`by_unit`), so one badly tracked joint is never averaged away by good ones."""
    error = np.asarray(error, dtype=float)
    error = error.reshape(len(error), -1)
    # Column by column: each a contiguous 1-D reduction, as the whole array of one joint is.
    rms = [float(np.sqrt(np.mean(error[:, j] ** 2))) for j in range(error.shape[1])]
    peak = [float(np.max(np.abs(error[:, j]))) for j in range(error.shape[1])]
    return {
        f"{prefix}_rms_per_joint": rms,
        f"{prefix}_max_per_joint": peak,
        **by_unit(f"{prefix}_rms", rms, units),
        **by_unit(f"{prefix}_max", peak, units),
    }


#: The effort unit of each joint position unit: a torque on a revolute joint, a force on a prismatic one.
EFFORT_UNITS = {"rad": "N·m", "m": "N"}


def in_units(values: Any, units: Sequence[str] = (), spec: str | None = None) -> str:
    """Per-joint ``values`` said with their ``units``: ``[30.0, 10.0] N·m`` when the joints share one unit,
    else ``[30 N·m, 10 N·m, 40 N]``; ``spec`` formats each number (None: as Python prints a float)."""
    values = [float(v) for v in np.atleast_1d(values)]
    if len(set(units)) <= 1:
        said = ", ".join(format(v, spec) if spec else repr(v) for v in values)
        return f"[{said}]" + (f" {units[0]}" if units else "")
    said = ", ".join(f"{v:{spec or 'g'}} {u}" for v, u in zip(np.broadcast_to(values, len(units)), units, strict=True))
    return f"[{said}]"


def by_unit(name: str, per_joint: list[float], units: list[str] | None, suffixes=("rad", "m")) -> dict[str, Any]:
    """The largest figure of the revolute joints as ``{name}_{suffixes[0]}`` (NaN with none: always
    there, for compatibility) and of the prismatic ones as ``{name}_{suffixes[1]}`` (if any); with only
    revolute joints, ``per_joint`` as ``{name}_{suffixes[0]}_per_joint`` too."""
    units = units or ["rad"] * len(per_joint)
    out: dict[str, Any] = {}
    for unit, suffix in zip(("rad", "m"), suffixes, strict=True):
        if (mine := [v for v, u in zip(per_joint, units, strict=True) if u == unit]) or unit == "rad":
            out[f"{name}_{suffix}"] = float(np.max(mine)) if mine else float("nan")
    if all(unit == "rad" for unit in units):
        out[f"{name}_{suffixes[0]}_per_joint"] = list(per_joint)
    return out


def peak_torque(command: np.ndarray, units: list[str] | None = None) -> dict[str, Any]:
    """Largest |command| of each joint (``peak_effort_per_joint``: N·m, or N on a prismatic joint) and
    the largest torque (``peak_torque_nm``) and force (``peak_force_n``) of all (:func:`by_unit`)."""
    command = np.asarray(command, dtype=float)
    command = command.reshape(len(command), -1)
    per_joint = [float(np.max(np.abs(command[:, j]))) for j in range(command.shape[1])]
    return {"peak_effort_per_joint": per_joint, **by_unit("peak", per_joint, units, ("torque_nm", "force_n"))}


STALL_S = 0.030
#: A loop period longer than this many nominal periods missed a cycle: as many as the ticks it lacks (a 30 ms period of
#: a 100 Hz loop, two), so that the count and the rate agree.
MISSED_PERIODS = 1.5


def missed_ticks(periods_s: np.ndarray, nominal_period_s: float) -> int:
    """The ticks the long periods among ``periods_s`` lack: each over ``MISSED_PERIODS`` periods, at least one."""
    long_s = np.asarray(periods_s, dtype=float)
    long_s = long_s[long_s > MISSED_PERIODS * nominal_period_s]
    return int(np.sum(np.maximum(np.rint(long_s / nominal_period_s) - 1.0, 1.0)))


def rate_metrics(tick_time_s: np.ndarray, nominal_period_s: float) -> dict[str, float]:
    """Achieved rate and period jitter (|period − nominal|) of a periodic loop."""
    t = np.asarray(tick_time_s, dtype=float)
    if len(t) < 2:
        raise ValueError("need at least two ticks to measure a rate")
    periods = np.diff(t)
    jitter_ms = np.abs(periods - nominal_period_s) * 1e3
    return {
        "control_rate_hz": float((len(t) - 1) / (t[-1] - t[0])),
        "jitter_p50_ms": float(np.percentile(jitter_ms, 50)),
        "jitter_p99_ms": float(np.percentile(jitter_ms, 99)),
        "jitter_max_ms": float(np.max(jitter_ms)),
        "missed_cycles": missed_ticks(periods, nominal_period_s),
        # a gap long enough to matter to an arm: three periods of a 100 Hz loop
        "stalls_30ms": int(np.count_nonzero(periods > STALL_S)),
        "longest_period_ms": float(np.max(periods) * 1e3),
    }


def periods_ending_within(ends_s: Sequence[float], tick_time_s: np.ndarray) -> int:
    """How many of the periods that ended at ``ends_s`` (s) are among those of ``tick_time_s``'s ticks (the
    periods :func:`rate_metrics` scores: each ends at a tick after the first)."""
    t = np.asarray(tick_time_s, dtype=float)
    if len(t) < 2:
        return 0
    ends = np.asarray(ends_s, dtype=float)
    return int(np.count_nonzero((ends > t[0]) & (ends <= t[-1])))


def missed_ticks_ending_at(ends_s: Sequence[float], tick_time_s: np.ndarray, nominal_period_s: float) -> int:
    """The ticks lacking (:func:`missed_ticks`) in the periods of ``tick_time_s`` that end at ``ends_s`` (s; within
    half a period of a tick after the first): the missed cycles among them a cause of their own (the host) made."""
    t = np.asarray(tick_time_s, dtype=float)
    ends = np.asarray(ends_s, dtype=float)
    if len(t) < 2 or ends.size == 0:
        return 0
    index = np.clip(np.searchsorted(t, ends), 1, len(t) - 1)
    nearer_before = (index > 1) & (np.abs(t[index - 1] - ends) < np.abs(t[index] - ends))
    index = np.where(nearer_before, index - 1, index)
    matched = np.unique(index[np.abs(t[index] - ends) < 0.5 * nominal_period_s])
    return missed_ticks(t[matched] - t[matched - 1], nominal_period_s)


def latency_metrics(latency_s: np.ndarray, prefix: str = "latency") -> dict[str, float]:
    lat_ms = np.asarray(latency_s, dtype=float) * 1e3
    lat_ms = lat_ms[np.isfinite(lat_ms)]
    if lat_ms.size == 0:
        return {}
    return {
        f"{prefix}_p50_ms": float(np.percentile(lat_ms, 50)),
        f"{prefix}_p99_ms": float(np.percentile(lat_ms, 99)),
        f"{prefix}_max_ms": float(np.max(lat_ms)),
    }


def step_metrics(
    time_s: np.ndarray,
    position: np.ndarray,
    *,
    initial: float,
    target: float,
    step_time_s: float = 0.0,
    settling_band: float = 0.02,
    torque: np.ndarray | None = None,
) -> dict[str, float]:
    """Step-response figures of one joint's position from ``initial`` to ``target`` commanded at ``step_time_s``
    (as python-control's ``step_info``): ``overshoot_pct``, ``rise_time_s`` (10–90 %), ``settling_time_s`` (last exit
    from ``settling_band``, a fraction of the step), ``steady_state_error_rad`` (mean |target − y| over the last
    10 % of the record), ``peak_torque_nm``."""
    t = np.asarray(time_s, dtype=float)
    y = np.asarray(position, dtype=float)
    after = t >= step_time_s
    t, y = t[after] - step_time_s, y[after]
    size = target - initial
    if size == 0 or len(t) < 3:
        raise ValueError("a step needs a non-zero size and at least three samples after it")
    progress = (y - initial) / size  # 0 → 1
    overshoot = max(0.0, float(np.max(progress)) - 1.0) * 100.0

    def first_crossing(level: float) -> float:
        idx = np.flatnonzero(progress >= level)
        if idx.size == 0:
            return np.nan
        k = idx[0]
        if k == 0:
            return float(t[0])
        # linear interpolation between samples for sub-sample accuracy
        p0, p1 = progress[k - 1], progress[k]
        return float(t[k - 1] + (level - p0) / (p1 - p0) * (t[k] - t[k - 1]))

    rise = first_crossing(0.9) - first_crossing(0.1)
    outside = np.flatnonzero(np.abs(progress - 1.0) > settling_band)
    if outside.size == 0:
        settling = 0.0
    elif outside[-1] == len(t) - 1:
        settling = np.nan  # never settled within the record
    else:
        settling = float(t[outside[-1] + 1])
    tail = y[int(0.9 * len(y)) :]
    out = {
        "overshoot_pct": overshoot,
        "rise_time_s": float(rise),
        "settling_time_s": settling,
        "steady_state_error_rad": float(np.mean(np.abs(target - tail))),
    }
    if torque is not None:
        out["peak_torque_nm"] = float(np.max(np.abs(np.asarray(torque, dtype=float))))
    return out
