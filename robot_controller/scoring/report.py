"""Score a run from its recording: the metrics of docs/design.md §7, tracking on the simulator's timeline, and
``metrics.json``. Works on any saved bag, so a run can be re-scored later (``robot-controller score DIR``)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import resources
from robot_controller.core import metrics
from robot_controller.core.controller import state_layout
from robot_controller.core.controller.supervision import Status
from robot_controller.core.model.mujoco_model import joint_names, joint_units, load_model
from robot_controller.scoring import summary
from robot_controller.scoring.bag_reader import (  # noqa: F401 - what scores a run reads first, importable here
    Recording,
    motor_latency_s,
    read_recording,
)


def arm_units(urdf_path: str) -> list[str]:
    """Each joint's position unit, ``"rad"`` or ``"m"``, of the arm at ``urdf_path`` ("": the reference arm)."""
    return joint_units(load_model(resources.resolve_urdf(urdf_path)))


def arm_joint_names(urdf_path: str) -> list[str]:
    """The joints of the arm at ``urdf_path`` ("": the reference arm), in its order."""
    return joint_names(load_model(resources.resolve_urdf(urdf_path)))


def score(
    recording: Recording,
    *,
    nominal_period_s: float = 0.01,
    warmup_s: float = metrics.WARMUP_S,
    window_s: float | None = None,
    units: list[str] | None = None,
    receipts: bool | None = None,
    judged_s: float | None = None,
) -> dict[str, Any]:
    """The run's metrics: tracking on the TRUE position, rates, latency, message counts.

    :param units: each joint's position unit, ``"rad"`` or ``"m"`` (default all ``"rad"``): the figures' names follow
    :param window_s: only the first ``window_s`` s of ticks, without what depends on when the recorder heard a message:
        on sim time, the same seed then gives the same figures exactly
    :param receipts: those figures all the same (default: only without ``window_s``); a paced world's run has them
    :param judged_s: the run's own span from its first tick (None: the whole recording): the stops and brakes of its
        shutdown after it (a split run's controller outliving the sensor's side) are not counted
    """
    s = recording.state
    keep = None
    if window_s is not None:
        keep = s["time_s"] < s["time_s"][0] + window_s - 1e-9
        s = {k: v[keep] for k, v in s.items()}
    ticks = s["time_s"]
    units = list(units or ["rad"] * recording.joint_count)
    out: dict[str, Any] = {"joint_names": list(recording.joint_names), "joint_units": units}
    end_s = ticks[0] + window_s if window_s is not None else ticks[-1]
    out.update(tracking_on_sim_timeline(recording, ticks[0] + warmup_s, end_s, nominal_period_s, units))
    out.update(start_transient(recording, ticks[0], out, nominal_period_s, units))
    pushed = pushed_at(recording, recording.true_time_s, PUSH_SETTLE_S)
    if np.any(pushed):  # what the band judges: the tracking away from the pushes someone asked for
        unpushed = tracking_on_sim_timeline(
            recording, ticks[0] + warmup_s, end_s, nominal_period_s, units, prefix="unpushed", leave_out=pushed
        )
        out.update({key: value for key, value in unpushed.items() if "_rms" not in key})
    # The sensor's own readings against the reference the law used with them (null if not recorded).
    active = s["status"] == state_layout.STATUS_CODES["ok"]
    raw = recording.raw_reading_at(s["measurement_stamp_s"])
    scored = active & (ticks >= ticks[0] + warmup_s) & np.all(np.isfinite(raw), axis=1)
    error = s["reference"][scored] - raw[scored] if np.any(scored) else np.full((1, len(units)), np.nan)
    measured = metrics.joint_errors(error, "measured", units)
    out.update({key: value for key, value in measured.items() if key.startswith("measured_rms")})
    out["malformed_messages"] = int(sum(recording.malformed.values()))
    out.update(metrics.rate_metrics(ticks, nominal_period_s))
    out["control_ticks"] = int(len(ticks))
    stops_end_s = min(end_s, ticks[0] + judged_s) if judged_s is not None else end_s
    status = s["status"][ticks <= stops_end_s + 1e-9]
    # Ticks spent handling a fault (stops, torque off, re-acquiring, e-stop): not tracking, so counted apart.
    for name in (*summary.FAULT_TICKS, "reacquiring"):
        out[f"{name}_ticks"] = int(np.count_nonzero(status == state_layout.STATUS_CODES[name]))
    out.update(brake_metrics(recording, ticks[0], min(stops_end_s, ticks[-1]), 2 * nominal_period_s))
    out["adapted_armature_kgm2"] = adapted_armature(recording.law_terms, recording.joint_count, keep)
    out["saturated_ticks"] = int(np.count_nonzero(np.any(s["saturated"] > 0.5, axis=1)))
    out["saturated_ticks_per_joint"] = np.count_nonzero(s["saturated"] > 0.5, axis=0).tolist()
    out.update(metrics.peak_torque(s["command"], units))
    out["recorded_duration_s"] = float(ticks[-1] - ticks[0])
    ok_ticks = s["status"] != state_layout.STATUS_CODES["no_measurement"]
    out.update(
        metrics.latency_metrics(s["time_s"][ok_ticks] - s["measurement_stamp_s"][ok_ticks], prefix="controller_latency")
    )
    if not (receipts if receipts is not None else window_s is None):
        return out
    out.update(metrics.latency_metrics(recording.motor_latency_s, prefix="latency"))
    for topic, times in recording.receipt_s.items():
        key = topic.strip("/").replace("/", "_")
        out[f"msgs_{key}"] = int(recording.counts.get(topic, len(times)))
        if len(times) > 1 and times[-1] > times[0]:
            out[f"rate_{key}_hz"] = float((len(times) - 1) / (times[-1] - times[0]))
    return out


def adapted_armature(law_terms: dict[str, np.ndarray], joint_count: int, keep: Any = None) -> list[float]:
    """kg·m² per joint, the armature the inertia adaptation had learnt by the last of the ticks ``keep`` selects (None:
    all); zeros with the adaptation off."""
    rows = law_terms.get(state_layout.ADAPTED_ARMATURE)
    if rows is None:
        rows = np.zeros((0, joint_count))
    elif keep is not None:
        rows = rows[keep]
    finite = rows[np.all(np.isfinite(rows), axis=1)]
    return finite[-1].tolist() if len(finite) else [0.0] * joint_count


def reference_in_force(recording: Recording, nominal_period_s: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """The reference in force at every true-state sample (:func:`reference_in_force_at`), and whether one is: none
    while the brakes hold the arm, a stop counted apart (``brake_engagements``), not tracking."""
    s, t = recording.state, recording.true_time_s
    in_force, valid = reference_in_force_at(s["time_s"], s["reference"], s["status"], t, nominal_period_s)
    return in_force, valid & ~braked_at(recording, t)


def braked_at(recording: Recording, t: np.ndarray) -> np.ndarray:
    """Whether the drive's brakes held any joint at each time ``t`` (from the brakes' state; never, if not recorded)."""
    if not len(recording.brakes_time_s):
        return np.zeros(len(t), bool)
    index = np.searchsorted(recording.brakes_time_s, t, side="right") - 1
    held = np.any(recording.brakes > 0.5, axis=1)
    return (index >= 0) & held[np.clip(index, 0, None)]


#: A span of the brakes an e-stop joined this soon after they engaged is the e-stop's (s); later, a fault the e-stop
#: found: the drive hears the e-stop first (its brake request, its efforts stopped) and the world the e-stop last.
ESTOP_JOIN_S = 0.5


def brake_metrics(recording: Recording, start_s: float, end_s: float, grace_s: float = 0.02) -> dict[str, Any]:
    """How often the brakes went on between ``start_s`` and ``end_s`` (and ``grace_s`` past it: the stop that ended a
    failed run), and for how long in all (sim s); of those, the ones an e-stop held (``…_estop``): asked for."""
    t, held = recording.brakes_time_s, np.any(recording.brakes > 0.5, axis=1)
    if not len(t):
        return {"brake_engagements": 0, "braked_s": 0.0, "brake_engagements_estop": 0, "braked_s_estop": 0.0}
    # Each span the brakes held without a break, and whether it was an e-stop's: one joined it within ESTOP_JOIN_S of
    # its start (what the e-stop sets off, the drive's brake request and the world's drive timeout, may come first).
    span_id = np.cumsum(held & ~np.concatenate(([False], held[:-1])))
    reasons = recording.brakes_reasons if len(recording.brakes_reasons) == len(t) else [frozenset()] * len(t)
    span_start_s: dict[int, float] = {}
    for k in np.flatnonzero(held):
        span_start_s.setdefault(int(span_id[k]), float(t[k]))
    estop_spans = {
        int(span_id[k])
        for k, said in enumerate(reasons)
        if held[k] and "estop" in said and t[k] - span_start_s[int(span_id[k])] <= ESTOP_JOIN_S
    }
    by_estop = np.isin(span_id, list(estop_spans)) & held
    engaged = np.flatnonzero(held[1:] & ~held[:-1]) + 1
    engaged = engaged[(t[engaged] > start_s) & (t[engaged] <= end_s + grace_s)]
    ends = np.append(t[1:], end_s)
    spans = np.clip(np.minimum(ends, end_s) - np.maximum(t, start_s), 0.0, None)
    return {
        "brake_engagements": int(len(engaged)),
        "braked_s": float(np.sum(spans[held])),
        "brake_engagements_estop": int(np.count_nonzero(by_estop[engaged])),
        "braked_s_estop": float(np.sum(spans[by_estop])),
    }


def reference_in_force_at(
    ticks: np.ndarray, reference: np.ndarray, status: np.ndarray, t: np.ndarray, nominal_period_s: float = 0.01
) -> tuple[np.ndarray, np.ndarray]:
    """The controller's reference in force at each time ``t`` (rad per joint), and whether one is: interpolated
    between ticks a period apart; across a longer gap (a stalled controller) the last one carried on at its speed for
    ``CARRY_S``, then held, so a stall cannot hide. None before the first tick or where the controller commands
    nothing (``IDLE_STATUSES``)."""
    index = np.clip(np.searchsorted(ticks, t, side="right") - 1, 0, len(ticks) - 1)
    following = np.clip(index + 1, 0, len(ticks) - 1)
    span = ticks[following] - ticks[index]
    interpolate = (following > index) & (span <= GAP_PERIODS * nominal_period_s)
    fraction = np.where(interpolate, (t - ticks[index]) / np.where(span > 0, span, 1.0), 0.0)[:, None]
    in_force = reference[index] + np.clip(fraction, 0.0, 1.0) * (reference[following] - reference[index])
    # Across a gap: the last reference, at the speed it had (from the tick before it).
    previous = np.clip(index - 1, 0, len(ticks) - 1)
    step_s = ticks[index] - ticks[previous]
    normal = (index > previous) & (step_s <= GAP_PERIODS * nominal_period_s)
    speed = np.where(
        normal[:, None], (reference[index] - reference[previous]) / np.where(step_s > 0, step_s, 1.0)[:, None], 0.0
    )
    carried = reference[index] + speed * np.clip(t - ticks[index], 0.0, CARRY_S)[:, None]
    in_force = np.where(interpolate[:, None], in_force, carried)
    idle = np.isin(status, [state_layout.STATUS_CODES[name] for name in IDLE_STATUSES])
    return in_force, (t >= ticks[0]) & ~idle[index]


def tracking_on_sim_timeline(
    recording: Recording,
    start_s: float,
    end_s: float,
    nominal_period_s: float = 0.01,
    units: list[str] | None = None,
    *,
    prefix: str = "tracking",
    leave_out: np.ndarray | None = None,
) -> dict[str, Any]:
    """Every true-state sample from ``start_s`` to ``end_s`` but those ``leave_out`` marks (a push and the settle
    after it) against the reference in force then, per joint and the worst joint's."""
    t, q = recording.true_time_s, recording.true_position
    in_force, valid = reference_in_force(recording, nominal_period_s)
    window = (t >= start_s - 1e-9) & (t <= end_s + 1e-9) & valid
    if leave_out is not None:
        window &= ~leave_out
    error = in_force[window] - q[window] if np.any(window) else np.full((1, recording.joint_count), np.nan)
    samples = {f"{'scored' if prefix == 'tracking' else prefix}_samples": int(np.count_nonzero(window))}
    return {**metrics.joint_errors(error, prefix=prefix, units=units), **samples}


def start_transient(
    recording: Recording, start_s: float, settled: dict[str, Any], nominal_period_s: float, units: list[str]
) -> dict[str, Any]:
    """The start, which the tracking figures leave out: its largest error (``start_tracking_max_rad``, per joint too)
    and when it ended (``start_transient_end_s``, from the first tick): the last sample of the start whose error is
    beyond what the joint's error reaches after it (``settled``: the figures after the start)."""
    end_s = start_s + metrics.WARMUP_S
    out = tracking_on_sim_timeline(recording, start_s, end_s, nominal_period_s, units, prefix="start_tracking")
    out = {key: value for key, value in out.items() if "_max" in key}
    t, q = recording.true_time_s, recording.true_position
    in_force, valid = reference_in_force(recording, nominal_period_s)
    window = (t >= start_s - 1e-9) & (t < end_s) & valid
    after = np.asarray(settled.get("tracking_max_per_joint") or [np.nan] * recording.joint_count, dtype=float)
    beyond = np.any(np.abs(in_force[window] - q[window]) > np.where(np.isfinite(after), after, np.inf), axis=1)
    out["start_transient_end_s"] = float(t[window][beyond][-1] - start_s) if np.any(beyond) else 0.0
    return out


def pushed_at(recording: Recording, t: np.ndarray, settle_s: float) -> np.ndarray:
    """Whether an external torque (the disturbance applied: a push someone asked for) acted at each time ``t``,
    or did less than ``settle_s`` before."""
    pushed = np.zeros(len(t), bool)
    times, torque = recording.disturbance_time_s, recording.disturbance
    acting = np.any(np.abs(torque) > 0.0, axis=1) if len(times) else np.zeros(0, bool)
    for k in np.flatnonzero(acting):
        until = times[k + 1] if k + 1 < len(times) else times[k]
        pushed |= (t >= times[k] - 1e-9) & (t <= until + settle_s)
    return pushed


#: s after a push (an external torque someone asked for) that the band does not judge: the arm is brought back.
PUSH_SETTLE_S = 1.0
# Ticks further apart than this many control periods: the controller was not running.
GAP_PERIODS = 5
# How long a drive goes on acting on the last command it got (motor command_timeout_s).
CARRY_S = 0.05
# Controller states that command no torque.
IDLE_STATUSES = tuple(status.value for status in Status if not status.commanding)


def json_safe(value: Any) -> Any:
    """NaN (a figure that could not be measured) as null: strict JSON."""
    if isinstance(value, float) and not np.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    return value


def write_metrics(path: Path, values: dict[str, Any]) -> None:
    path.write_text(json.dumps(json_safe(values), indent=2, sort_keys=True, allow_nan=False) + "\n")


# metrics.json's per-joint lists in the summary's order: column heading, whether in effort units (else position's).
PER_JOINT_KEYS = {
    "tracking_rms_per_joint": ("tracking\nRMS", False),
    "tracking_max_per_joint": ("tracking\nmax", False),
    "measured_rms_per_joint": ("measured\nRMS", False),
    "peak_effort_per_joint": ("peak\neffort", True),
}


def joint_table(values: dict[str, Any], title: str = "per joint (worst in bold: the headline figure)"):
    """A ``rich`` table of the per-joint figures, a row per joint in its units; None for one joint (the headline's)."""
    names = values.get("joint_names") or []
    if len(names) < 2:
        return None
    from rich.markup import escape
    from rich.table import Table

    from robot_controller.core.metrics import EFFORT_UNITS

    units = values.get("joint_units") or ["rad"] * len(names)
    keys = [key for key in PER_JOINT_KEYS if len(values.get(key) or []) == len(names)]
    table = Table(title=title)
    table.add_column("joint")
    for key in keys:
        heading, effort = PER_JOINT_KEYS[key]
        shown = dict.fromkeys(EFFORT_UNITS[u] if effort else u for u in units)
        table.add_column(escape(f"{heading} [{' | '.join(shown)}]"), justify="right")  # "[rad]" is not markup
    worst = {key: _worst(values[key], units) for key in keys}
    for j, name in enumerate(names):
        cells = []
        for key in keys:
            value = values[key][j]
            text = "—" if value is None or not np.isfinite(value) else f"{value:.6g}"
            cells.append(f"[bold]{text}[/bold]" if j in worst[key] else text)
        table.add_row(escape(name if units[j] == "rad" else f"{name} [{units[j]}, {EFFORT_UNITS[units[j]]}]"), *cells)
    return table


def _worst(figures: list[float | None], units: list[str]) -> set[int]:
    """The worst joint of each unit: each a headline figure (``metrics.by_unit``)."""
    worst: dict[str, int] = {}
    for j, (value, unit) in enumerate(zip(figures, units, strict=True)):
        if value is not None and np.isfinite(value) and (unit not in worst or value > figures[worst[unit]]):
            worst[unit] = j
    return set(worst.values())
