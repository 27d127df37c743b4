"""The run's picture: reference, true and measured position; error; torque."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from robot_controller.core import metrics
from robot_controller.scoring.bag_reader import Recording


def plot_tracking(recording: Recording, path: Path, title: str = "") -> None:
    """Reference, true and measured position; tracking error; commanded and applied torque."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = recording.state
    t0 = s["time_s"][0]
    t = s["time_s"] - t0
    true_at_tick = metrics.true_position_at(
        s["time_s"], recording.true_time_s, recording.true_position, recording.true_velocity
    )
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True, constrained_layout=True)
    for j in range(recording.joint_count):
        tag = f" j{j + 1}" if recording.joint_count > 1 else ""
        axes[0].plot(t, s["reference"][:, j], "k--", lw=1.2, label=f"reference{tag}")
        axes[0].plot(t, true_at_tick[:, j], lw=1.2, label=f"true{tag}")
        axes[0].plot(t, s["measured"][:, j], ".", ms=1.5, alpha=0.5, label=f"measured{tag}")
        axes[1].plot(t, (s["reference"][:, j] - true_at_tick[:, j]) * 1e3, lw=1, label=f"reference − true{tag}")
        axes[1].plot(
            t, (s["reference"][:, j] - s["measured"][:, j]) * 1e3, lw=0.5, alpha=0.4, label=f"reference − measured{tag}"
        )
        axes[2].plot(t, s["command"][:, j], lw=1, label=f"command{tag}")
        axes[2].plot(recording.true_time_s - t0, recording.true_effort[:, j], lw=0.8, alpha=0.7, label=f"applied{tag}")
    axes[0].set_ylabel("position [rad]")
    axes[1].set_ylabel("error [mrad]")
    axes[2].set_ylabel("torque [N·m]")
    axes[2].set_xlabel("time since first control tick [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    ax1_lim = np.nanpercentile(np.abs((s["reference"] - s["measured"]) * 1e3), 99.5) * 1.3
    if np.isfinite(ax1_lim) and ax1_lim > 0:
        axes[1].set_ylim(-ax1_lim, ax1_lim)
    axes[2].set_xlim(t[0], t[-1])
    if title:
        fig.suptitle(title)
    fig.savefig(path, dpi=110)
    plt.close(fig)
