"""What the network bench runs and how each run is scored: the splits of the
graph over the two hosts, the network conditions, and the figures of one run
(from the robot host's recording and metrics). Plain data and functions: no
namespaces, no processes (those are ``netns`` and ``bench``)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

ALL_NODES = ("simulator", "motor_node", "sensor_node", "pid_controller", "trajectory_planner")
CUT_AT_S = 5.0  #: a cut starts this long after the loop closes: mid-motion on the 0.5 Hz sine
AFTER_CUT_S = 4.0  #: control recorded after a cut ends
GOAL_DEVIATION_RAD = 0.1
CONTROL_RATE_HZ = 100.0  #: the reference scenario's controller
#: The loop ran: at least this share of the run's controller ticks recorded, and of its scored time unbraked.
RAN_SHARE = 0.5
REACQUIRED_RAD = 0.002
REACQUIRED_HOLD_S = 0.1
#: The loop's reactions, ticks in each state (metrics.json).
REACTIONS = (
    "watchdog_ticks",
    "sensor_lost_ticks",
    "reference_lost_ticks",
    "reacquiring_ticks",
    "late_ticks",
    "late_stopped_ticks",
    "stopped_ticks",
)


@dataclass(frozen=True)
class Split:
    name: str
    control_nodes: tuple[str, ...]  #: on the control host; the rest on the robot host, with the recorder
    note: str

    @property
    def robot_nodes(self) -> tuple[str, ...]:
        return tuple(n for n in ALL_NODES if n not in self.control_nodes)


SPLITS = (
    Split("planner_remote", ("trajectory_planner",), "the recommended deployment: only the plan crosses the link"),
    Split(
        "controller_remote",
        ("pid_controller", "trajectory_planner"),
        "the hard one: readings and commands cross the link every period",
    ),
)


@dataclass(frozen=True)
class Condition:
    name: str
    text: str
    loss_pct: int = 0
    rate_kbit: int = 0  #: a tbf cap on each end (0: none)
    burst_bytes: int = 4096
    queue_ms: float = 50.0  #: tbf's latency: how long a packet may wait in its queue
    cut_s: float = 0.0  #: the link down this long, CUT_AT_S after the loop closes
    sensor_delay_s: float = 0.0  #: the sensor's honest delay_s (its readings stamped with the sample time)

    def config(self) -> dict[str, Any] | None:
        """The parameter overlay this condition needs (a ROS parameter file's content), or None."""
        if not self.sensor_delay_s:
            return None
        return {"sensor_node": {"ros__parameters": {"delay_s": self.sensor_delay_s}}}


CONDITIONS = (
    Condition("clean", "no impairment"),
    Condition("loss_1", "1 % of packets lost each way", loss_pct=1),
    Condition("loss_5", "5 % lost each way", loss_pct=5),
    Condition("loss_20", "20 % lost each way", loss_pct=20),
    Condition("cap_2mbit", "tbf 2 Mbit/s each way, 50 ms queue", rate_kbit=2000),
    Condition("cap_500kbit", "tbf 500 kbit/s each way, 200 ms queue (queueing delay)", rate_kbit=500, queue_ms=200.0),
    Condition("cut_0.2", "link down 0.2 s mid-motion", cut_s=0.2),
    Condition("cut_2", "link down 2 s mid-motion", cut_s=2.0),
    Condition("sensor_delay_20ms", "sensor delay_s 20 ms (readings late, stamped honestly)", sensor_delay_s=0.02),
)
QUICK = (("planner_remote", "clean"), ("controller_remote", "cut_0.2"))


def runs(quick: bool) -> list[tuple[Split, Condition]]:
    splits = {s.name: s for s in SPLITS}
    conditions = {c.name: c for c in CONDITIONS}
    if quick:
        return [(splits[s], conditions[c]) for s, c in QUICK]
    return [(s, c) for s in SPLITS for c in CONDITIONS]


def duration_s(condition: Condition, quick: bool) -> float:
    """Seconds of control recorded: a cut needs time before and after it."""
    if condition.cut_s:
        return CUT_AT_S + condition.cut_s + AFTER_CUT_S
    return 8.0 if quick else 12.0


def band_figures(recording, from_s: float, cut_end_s: float | None) -> dict[str, Any]:
    """From ``from_s`` on (the run's clock, s): how far the TRUE angle went outside the band the reference
    sweeps, the largest error from the plan, and (after a cut ending at ``cut_end_s``) when every joint was
    back within 2 mrad of the plan for 0.1 s; whether the brakes engaged. With no plan: how far the arm moved."""
    planned_t, planned_q = recording.planned_time_s, recording.planned_position
    true_t, true_q = recording.true_time_s, recording.true_position
    if not len(planned_t) or not len(true_t):  # no plan arrived (a link too slow for it): no band to keep
        moved = float(np.max(np.abs(true_q - true_q[0]))) if len(true_t) else None
        return {
            "band_deviation_rad": moved,
            "max_error_from_plan_rad": None,
            "reacquire_s": None,
            "brakes_engaged": None,
            "braked_fraction": braked_fraction(recording, from_s),
        }
    low, high = np.min(planned_q, axis=0), np.max(planned_q, axis=0)
    after = true_t >= from_s
    outside = np.max(np.maximum(0.0, np.maximum(true_q - high, low - true_q)), axis=1)
    plan = np.column_stack([np.interp(true_t, planned_t, planned_q[:, j]) for j in range(planned_q.shape[1])])
    error = np.max(np.abs(true_q - plan), axis=1)
    reacquire_s = None
    if cut_end_s is not None:
        within = (true_t >= cut_end_s) & (error < REACQUIRED_RAD)
        for start in np.flatnonzero(within):
            window = (true_t >= true_t[start]) & (true_t < true_t[start] + REACQUIRED_HOLD_S)
            if true_t[-1] >= true_t[start] + REACQUIRED_HOLD_S and np.all(within[window]):
                reacquire_s = float(true_t[start] - cut_end_s)
                break
    last_tick_s = recording.state["time_s"][-1] - 0.1  # the run's own end brakes the arm: not counted
    braked = (
        (recording.brakes_time_s >= from_s)
        & (recording.brakes_time_s <= last_tick_s)
        & np.any(recording.brakes > 0.5, axis=1)
    )
    return {
        "band_deviation_rad": float(np.max(outside[after])) if np.any(after) else None,
        "max_error_from_plan_rad": float(np.max(error[after])) if np.any(after) else None,
        "reacquire_s": reacquire_s,
        "brakes_engaged": bool(np.any(braked)),
        "braked_fraction": braked_fraction(recording, from_s),
    }


def braked_fraction(recording, from_s: float) -> float | None:
    """The share of the time from ``from_s`` to the last tick (less its end's 0.1 s) that any brake was engaged,
    each /sim/brakes sample held until the next; None without ticks or brake samples."""
    if not len(recording.state["time_s"]) or not len(recording.brakes_time_s):
        return None
    end_s = recording.state["time_s"][-1] - 0.1
    if end_s <= from_s:
        return None
    t = np.clip(np.append(recording.brakes_time_s, end_s), from_s, end_s)
    on = np.any(recording.brakes > 0.5, axis=1)
    return float(np.sum(np.diff(t)[on]) / (end_s - from_s))


def message_figures(counts: dict[str, int], published: dict[str, int], span_s: float) -> dict[str, Any]:
    """Per topic: what the robot host's recorder holds, its rate over ``span_s``, and for the topics the robot
    host's own nodes publish, how many of those are missing (``lost``; the control host counts nothing)."""
    out: dict[str, Any] = {}
    for topic, count in sorted(counts.items()):
        entry: dict[str, Any] = {"recorded": int(count), "rate_hz": count / span_s if span_s > 0 else None}
        if topic in published:
            entry["published_here"] = int(published[topic])
            entry["lost"] = int(published[topic]) - int(count)
        out[topic] = entry
    return out


def run_figures(run_dir: Path, split: Split, condition: Condition, cut: tuple[float, float] | None) -> dict[str, Any]:
    """One run's figures from the robot host's ``metrics.json``, ``published.json`` and bag."""
    from robot_controller.scoring import report

    metrics = json.loads((run_dir / "metrics.json").read_text()) if (run_dir / "metrics.json").exists() else {}
    published = json.loads((run_dir / "published.json").read_text()) if (run_dir / "published.json").exists() else {}
    figures: dict[str, Any] = {
        "verdict": metrics.get("verdict"),
        "run_failure": metrics.get("run_failure"),
        "tracking_rms_rad": metrics.get("tracking_rms_rad"),
        "tracking_max_rad": metrics.get("tracking_max_rad"),
        "latency_p99_ms": metrics.get("latency_p99_ms"),
        "control_rate_hz": metrics.get("control_rate_hz"),
    }
    figures.update({key: metrics.get(key) for key in REACTIONS})
    bag = run_dir / "bag"
    if not bag.exists() or not metrics:
        return figures | {"failure": "no recording"}
    recording = report.read_recording(bag)
    if cut is not None:
        figures.update(band_figures(recording, cut[0], cut[1]))
    else:
        first_tick = float(recording.state["time_s"][0])
        figures.update(band_figures(recording, first_tick + 2.0, None))
    span = float(recording.state["time_s"][-1] - recording.state["time_s"][0])
    figures["messages"] = message_figures(dict(recording.counts), published, span)
    return figures


def within_goal(entry: dict[str, Any]) -> bool:
    deviation = entry.get("band_deviation_rad")
    return deviation is not None and deviation <= GOAL_DEVIATION_RAD


def not_run(entry: dict[str, Any]) -> str | None:
    """Why the loop did not run in this case (a launcher's exit code, no plan at the robot host, too few controller
    ticks recorded, braked most of the scored time), or None: it ran. Ticks and brakes unknown are not held against
    it (an older report). The robot's launcher exits 1 for a run that ran and was judged FAILED (a cut link's stop
    is a stop nobody asked for): that is this bench's to judge by its band, not a run that did not run."""
    judged_only = entry.get("robot_exit") == 1 and entry.get("verdict") == "failed" and not entry.get("run_failure")
    if (entry.get("robot_exit") != 0 and not judged_only) or entry.get("control_exit") != 0:
        return f"exit {entry.get('robot_exit')}/{entry.get('control_exit')}"
    messages = entry.get("messages") or {}
    if not messages.get("/trajectory", {}).get("recorded"):
        return "no plan arrived"
    ticks, expected = messages.get("/controller/state", {}).get("recorded", 0), entry["duration_s"] * CONTROL_RATE_HZ
    if ticks < RAN_SHARE * expected:
        return f"{ticks} controller ticks of {expected:.0f}"
    if (braked := entry.get("braked_fraction")) is not None and braked > RAN_SHARE:
        return f"braked {braked:.0%} of the time"
    return None


def passed(entry: dict[str, Any]) -> bool:
    """The loop ran (``not_run``) and kept the TRUE angle within ``GOAL_DEVIATION_RAD`` of its band."""
    return not_run(entry) is None and within_goal(entry)
