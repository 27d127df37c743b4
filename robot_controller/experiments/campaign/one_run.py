"""One run of a campaign: its draws over the campaign's stack, the in-process loop (the nodes' core code, no ROS) for
the campaign's duration, and its row of figures. A run that raises is a row too, failed with its reason."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.core.controller.supervision import Status
from robot_controller.experiments.campaign.spec import FIGURES, columns, layer

#: The statuses of a tick the controller spends stopping or stopped rather than tracking.
STOP_STATUSES = frozenset(
    (
        Status.WATCHDOG,
        Status.SENSOR_LOST,
        Status.REFERENCE_LOST,
        Status.STOPPED,
        Status.LAW_FAULT,
        Status.LAW_STOPPED,
        Status.LATE,
        Status.LATE_STOPPED,
    )
)
#: An applied torque this close to its limit (as a fraction of it) counts as saturated.
SATURATED_FRACTION = 0.999
#: The row's columns that are the host's, not the run's: left out when two campaigns' figures are compared.
HOST_COLUMNS = ("wall_s", "cpu_s", "attempts", "first_failure")


@dataclass(frozen=True)
class Task:
    """What a worker needs for one run (pickled to a process or a Ray worker)."""

    run_id: int
    controller: str  #: the label of the compared controller ("" for the spec's only one)
    params: cfg.Params  #: the campaign's stack with this controller
    drawn: dict[str, Any]
    seed: int
    duration_s: float
    timeout_s: float = math.inf  #: the run's wall-time limit, s (``executors`` holds it to it)


def head(task: Task) -> dict[str, Any]:
    """The columns that name the run: ``run_id``, ``controller``, ``seed`` and every drawn value."""
    row: dict[str, Any] = {"run_id": task.run_id, "controller": task.controller, "seed": task.seed}
    row.update(columns(task.drawn))
    return row


def run(task: Task) -> dict[str, Any]:
    """Task's row: ``run_id``, ``controller``, ``seed``, every drawn value, every figure, ``status`` and ``reason``."""
    row = head(task)
    start, cpu_start = time.perf_counter(), time.process_time()
    try:
        row.update(figures(run_params(task.params, task.drawn, task.seed), task.duration_s, task.seed))
    except Exception as exc:  # noqa: BLE001 - a world the stack refuses or a loop that breaks: a row, not a crash
        row.update(status="failed", reason=" ".join(f"{type(exc).__name__}: {exc}".split())[:300])
    row["wall_s"] = time.perf_counter() - start
    row["cpu_s"] = time.process_time() - cpu_start  # beside wall_s: how much of the core the host gave the run
    return row


def run_params(params: cfg.Params, drawn: dict[str, Any], seed: int) -> cfg.Params:
    """The stack of one run: the draws over the campaign's stack, each value checked by its schema, the seed."""
    drawn_layer = layer(drawn)
    for node, values in drawn_layer.items():
        for name, value in values.items():
            values[name] = cfg.spec_of(node, name).validate(value)
    return cfg.merge(params, drawn_layer, {"sensor_node": {"seed": seed}})


def figures(params: cfg.Params, duration_s: float, seed: int) -> dict[str, Any]:
    """The figures of one in-process run of ``params``: the worst joint's tracking (RMS and largest, on the true
    angle), the peak commanded effort (and against the limit), the ticks the drive's torque is at its limit, the
    controller's stops."""
    from robot_controller.experiments import inprocess
    from robot_controller.parameters.torque_limits import torque_limit

    loop = inprocess.prepare(params, duration_s=duration_s, seed=seed)  # the sensor block delays its readings
    watched = _StatusWatch(loop.keywords["controller"])
    result = loop(controller=watched)
    if not np.all(np.isfinite(result.true_position)):
        raise RuntimeError("the arm's state went non-finite (the physics diverged)")
    tracking = result.tracking_metrics()
    n = result.applied.shape[1]
    limit = torque_limit(params["motor_node"], n)
    effort = np.abs(result.command)  # what the controller asked (a run's peak_torque_nm is of its commands)
    out: dict[str, Any] = {"status": "ok", "reason": ""}
    for key in FIGURES:  # the worst joint's tracking, and of the start (the others are set below)
        if key in tracking:
            out[key] = float(tracking[key])
    worst = int(np.argmax(tracking["tracking_rms_per_joint"]))
    out["worst_joint"] = tracking["joint_names"][worst]
    out["peak_effort"] = float(effort.max())
    out["peak_effort_ratio"] = float((effort.max(axis=0) / limit).max())
    at_limit = np.abs(result.applied) >= SATURATED_FRACTION * limit  # the drive's torque, at its limit
    out["saturated_ticks"] = int(np.count_nonzero(np.any(at_limit, axis=1)))
    out["stopped_ticks"] = watched.stopped_ticks
    out["faults"] = watched.stops + (1 if result.law_fault and not watched.stops else 0)
    out["law_fault"] = result.law_fault or ""
    return out


class _StatusWatch:
    """The controller as the loop uses it, counting the ticks it spends stopping and how often a stop begins."""

    def __init__(self, controller) -> None:
        self._controller = controller
        self.stopped_ticks = 0
        self.stops = 0
        self._stopping = False

    def update(self, now_s: float):
        out = self._controller.update(now_s)
        stopping = out.status in STOP_STATUSES
        self.stopped_ticks += stopping
        self.stops += stopping and not self._stopping
        self._stopping = stopping
        return out

    def __getattr__(self, name: str):
        return getattr(self._controller, name)
