"""The run's picture (``tracking.png``): the reference, the true position, the sensor's readings and the controller's
estimate; the tracking error; the commanded and applied effort. One joint: three panels stacked; more: one row per
joint, the three panels side by side, each joint on its own scale and named with its units. The traces' names are
the live view's too (``TRACES``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robot_controller.blocks import spec
from robot_controller.core import metrics
from robot_controller.scoring.bag_reader import Recording

#: What each trace is, by key, in tracking.png and the live view alike; ``{q}``: the quantity (:func:`quantity`).
TRACES = {
    "reference": "reference",
    "true": f"true {{q}} ({spec.TRUE_STATE.topic})",
    "readings": f"sensor readings ({spec.READING.topic}, noisy)",
    "estimate": f"controller's estimate ({spec.STATE.topic})",
    "error_true": "reference − true {q} (scored)",
    "error_estimate": "reference − estimate (the controller's error)",
    "commanded": "commanded",
    "applied": f"applied ({spec.TRUE_STATE.topic})",
}
#: When the controller acts on the readings as they are (``estimator: none``): its estimate is the reading.
UNFILTERED = {
    "readings": f"sensor readings ({spec.READING.topic}, noisy; the controller's input, no estimator)",
    "error_estimate": "reference − reading (the controller's error, no estimator)",
}
#: The error panel's limits: this much beyond the largest error drawn, so that no feature is cut.
ERROR_MARGIN = 1.08


def quantity(units: list[str]) -> str:
    """What a position is on joints in ``units``: an angle (all revolute, rad) or a position."""
    return "angle" if all(unit == "rad" for unit in units) else "position"


def trace_name(key: str, units: list[str]) -> str:
    """The name of trace ``key`` (of :data:`TRACES`) on joints in ``units``."""
    return TRACES[key].format(q=quantity(units))


def headings(units: list[str]) -> tuple[str, str, str]:
    """The position, error (milli-) and effort axes' headings for joints in ``units`` (rad or m)."""
    shown, small = " | ".join(dict.fromkeys(units)), " | ".join("m" + u for u in dict.fromkeys(units))
    efforts = " | ".join(dict.fromkeys(metrics.EFFORT_UNITS[u] for u in units))
    effort = "torque" if efforts == "N·m" else "force" if efforts == "N" else "effort"
    return f"position [{shown}]", f"error [{small}]", f"{effort} [{efforts}]"


def estimate_is_the_reading(recording: Recording) -> bool:
    """Whether the controller's estimate is the sensor's reading itself (no estimator): where both are recorded,
    equal to the bit."""
    s = recording.state
    readings = recording.raw_reading_at(s["measurement_stamp_s"])
    found = np.all(np.isfinite(readings), axis=1)
    return bool(np.any(found)) and bool(np.array_equal(readings[found], s["measured"][found]))


def error_limit(*errors: np.ndarray) -> float | None:
    """The error panel's half-height: every error drawn, whole (None: nothing finite to draw)."""
    finite = [np.abs(e[np.isfinite(e)]) for e in errors]
    largest = max((float(np.max(e)) for e in finite if e.size), default=0.0)
    return ERROR_MARGIN * largest if largest > 0 else None


def plot_tracking(recording: Recording, path: Path, title: str = "", units: list[str] | None = None) -> None:
    """Reference, true position, the sensor's readings and the controller's estimate; tracking error; commanded and
    applied effort, for every joint; ``units``: each joint's position unit, ``"rad"`` (default) or ``"m"`` (a
    prismatic joint)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = recording.state
    t0 = s["time_s"][0]
    t = s["time_s"] - t0
    true_at_tick = recording.true_at_ticks()
    n = recording.joint_count
    units = units or ["rad"] * n
    unfiltered = estimate_is_the_reading(recording)
    if n == 1:
        fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True, constrained_layout=True)
        rows = [axes]
    else:
        fig, grid = plt.subplots(n, 3, figsize=(16, 1.1 + 2.0 * n), sharex=True, squeeze=False, constrained_layout=True)
        rows = list(grid)
    name = {key: trace_name(key, units) for key in TRACES} | (UNFILTERED if unfiltered else {})
    readings_t = recording.reading_stamp_s - t0
    # A colour per signal, the same in every panel: the true position's, the readings', the estimate's.
    true_colour, readings_colour, estimate_colour = "C0", "C1", "C1" if unfiltered else "C2"
    for j, (position, error, torque) in enumerate(rows):
        position.plot(t, s["reference"][:, j], "k--", lw=1.2, label=name["reference"])
        if len(readings_t):
            reading = recording.reading_position[:, j]
            position.plot(readings_t, reading, ".", ms=1.5, alpha=0.4, color=readings_colour, label=name["readings"])
        position.plot(t, true_at_tick[:, j], lw=1.2, color=true_colour, label=name["true"])
        if not unfiltered:
            position.plot(t, s["measured"][:, j], lw=0.8, alpha=0.8, color=estimate_colour, label=name["estimate"])
        error_true = (s["reference"][:, j] - true_at_tick[:, j]) * 1e3
        error_estimate = (s["reference"][:, j] - s["measured"][:, j]) * 1e3
        error.plot(t, error_true, lw=1, color=true_colour, label=name["error_true"])
        error.plot(t, error_estimate, lw=0.5, alpha=0.5, color=estimate_colour, label=name["error_estimate"])
        limit = error_limit(error_true, error_estimate)
        if limit is not None:
            error.set_ylim(-limit, limit)
        torque.plot(t, s["command"][:, j], lw=1, label=name["commanded"])
        torque.plot(recording.true_time_s - t0, recording.true_effort[:, j], lw=0.8, alpha=0.7, label=name["applied"])
        for ax in (position, error, torque):
            ax.grid(alpha=0.3)
    last = rows[-1]
    last[-1].set_xlim(t[0], t[-1])
    for ax, heading in zip(rows[0], headings(units), strict=True):  # one joint: stacked, labelled on the left
        if n == 1:
            ax.set_ylabel(heading)
        else:
            ax.set_title(heading, fontsize=10)
        ax.legend(loc="upper right", fontsize=8 if n == 1 else 7)
    for ax in last if n > 1 else last[-1:]:
        ax.set_xlabel("time since first control tick [s]")
    if n > 1:  # each panel's unit beside its joint's name
        for row, joint, unit in zip(rows, recording.joint_names, units, strict=True):
            for ax, heading in zip(row, headings([unit]), strict=True):
                ax.set_ylabel(f"{joint}\n{heading}", fontsize=8)
                ax.tick_params(labelsize=8)
    if title:
        fig.suptitle(title)
    fig.savefig(path, dpi=110)
    plt.close(fig)
