"""The in-process loop's record (``blocks.wiring.LoopResult``) scored as a sim-time run's bag is: the same functions on
the same samples, so an in-process experiment says what the graph's says (``compare --in-process``).

A sim-time run's scorer (``report.score`` with its ``window_s``) takes every true-state sample from its first tick to
its duration's end, both ends in: the last is the world's state after the last tick, which the simulator publishes
at the next tick's time, its reference that tick's. The loop records the true state at each tick, before the tick's
command, so run a period past the duration it holds that sample, and its reference, too."""

from __future__ import annotations

from typing import Any

import numpy as np

from robot_controller.blocks.wiring import LoopResult
from robot_controller.core import metrics
from robot_controller.scoring import report
from robot_controller.scoring.bag_reader import Recording


def as_recording(result: LoopResult) -> Recording:
    """What the scorer reads of a bag, from the loop's record: the controller's ticks (their time, reference and
    status) and the true state at each tick. No brakes: the loop's drive brakes only after ticks that command
    nothing, which the scorer leaves out by their status."""
    ticks = len(result.tick_time_s)
    status = result.status_code if len(result.status_code) == ticks else np.zeros(ticks)  # unrecorded: all ``ok``
    state = {"time_s": result.tick_time_s, "reference": result.reference, "status": status}
    return Recording(
        state=state,
        true_time_s=result.tick_time_s,
        true_position=result.true_position,
        true_velocity=result.true_velocity,
        true_effort=result.applied,
        recorded_joint_names=list(result.joint_names),
    )


def tracking(result: LoopResult, duration_s: float, period_s: float) -> dict[str, Any]:
    """``tracking_*`` (from ``metrics.WARMUP_S``), ``scored_samples`` and ``start_tracking_max_*`` of a sim-time run
    of ``duration_s`` s as its scorer gives them, from a loop run of ``duration_s`` plus at least one ``period_s``.

    :raises ValueError: the loop ran for less than that
    """
    t = result.tick_time_s
    end_s = t[0] + duration_s
    if t[-1] < end_s - 1e-9:
        raise ValueError(f"the loop ran to {t[-1]:.3f} s: scoring {duration_s:g} s needs its tick at the end")
    recording, units = as_recording(result), list(result.joint_units)
    out = report.tracking_on_sim_timeline(recording, t[0] + metrics.WARMUP_S, end_s, period_s, units)
    start = report.start_transient(recording, t[0], out, period_s, units)
    return out | {key: value for key, value in start.items() if key.startswith("start_tracking")}
