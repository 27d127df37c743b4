"""The figures of one campaign run (:func:`figures`): the in-process loop on the run's stack, scored as the graph's run
is, and the controller's stops counted as they happen."""

from __future__ import annotations

from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.core.controller.supervision import Status
from robot_controller.experiments.campaign.spec import FIGURES

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
