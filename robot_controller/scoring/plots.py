"""The run's picture: reference, true and measured position; error; torque. One joint: three panels stacked; more:
one row per joint, the three panels side by side, each joint on its own scale."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robot_controller.core import metrics
from robot_controller.scoring.bag_reader import Recording


def headings(units: list[str]) -> tuple[str, str, str]:
    """The position, error (milli-) and effort axes' headings for joints in ``units`` (rad or m)."""
    shown, small = " | ".join(dict.fromkeys(units)), " | ".join("m" + u for u in dict.fromkeys(units))
    efforts = " | ".join(dict.fromkeys(metrics.EFFORT_UNITS[u] for u in units))
    effort = "torque" if efforts == "N·m" else "force" if efforts == "N" else "effort"
    return f"position [{shown}]", f"error [{small}]", f"{effort} [{efforts}]"


def plot_tracking(recording: Recording, path: Path, title: str = "", units: list[str] | None = None) -> None:
    """Reference, true and measured position; tracking error; commanded and applied effort, for every
    joint; ``units``: each joint's position unit, ``"rad"`` (default) or ``"m"`` (a prismatic joint)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = recording.state
    t0 = s["time_s"][0]
    t = s["time_s"] - t0
    true_at_tick = recording.true_at_ticks()
    n = recording.joint_count
    if n == 1:
        fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True, constrained_layout=True)
        rows = [axes]
    else:
        fig, grid = plt.subplots(n, 3, figsize=(16, 1.1 + 2.0 * n), sharex=True, squeeze=False, constrained_layout=True)
        rows = list(grid)
    for j, (position, error, torque) in enumerate(rows):
        position.plot(t, s["reference"][:, j], "k--", lw=1.2, label="reference")
        position.plot(t, true_at_tick[:, j], lw=1.2, label="true")
        position.plot(t, s["measured"][:, j], ".", ms=1.5, alpha=0.5, label="measured")
        error.plot(t, (s["reference"][:, j] - true_at_tick[:, j]) * 1e3, lw=1, label="reference − true")
        error.plot(
            t, (s["reference"][:, j] - s["measured"][:, j]) * 1e3, lw=0.5, alpha=0.4, label="reference − measured"
        )
        torque.plot(t, s["command"][:, j], lw=1, label="command")
        torque.plot(recording.true_time_s - t0, recording.true_effort[:, j], lw=0.8, alpha=0.7, label="applied")
        # The error's scale from the reading's spread; with several joints, widened to each whole true error.
        limit = np.nanpercentile(np.abs((s["reference"][:, j] - s["measured"][:, j]) * 1e3), 99.5) * 1.3
        scored = np.abs(s["reference"][t >= metrics.WARMUP_S, j] - true_at_tick[t >= metrics.WARMUP_S, j]) * 1e3
        if n > 1 and np.any(np.isfinite(scored)):
            limit = max(limit, 1.1 * float(np.nanmax(scored)))
        if np.isfinite(limit) and limit > 0:
            error.set_ylim(-limit, limit)
        for ax in (position, error, torque):
            ax.grid(alpha=0.3)
    last = rows[-1]
    last[-1].set_xlim(t[0], t[-1])
    units = units or ["rad"] * n
    for ax, heading in zip(rows[0], headings(units), strict=True):  # one joint: stacked, labelled on the left
        if n == 1:
            ax.set_ylabel(heading)
        else:
            ax.set_title(heading, fontsize=10)
        ax.legend(loc="upper right", fontsize=8 if n == 1 else 7)
    for ax in last if n > 1 else last[-1:]:
        ax.set_xlabel("time since first control tick [s]")
    if n > 1:
        for row, name, unit in zip(rows, recording.joint_names, units, strict=True):
            row[0].set_ylabel(name if unit == "rad" else f"{name} [{unit}]", fontsize=9)
            for ax in row:
                ax.tick_params(labelsize=8)
    if title:
        fig.suptitle(title)
    fig.savefig(path, dpi=110)
    plt.close(fig)
