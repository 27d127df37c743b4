"""``compare``'s table as markdown (``compare.md``) and as a figure (``compare.png``)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from robot_controller.experiments.compare.contenders import CONTENDERS, Contender
from robot_controller.experiments.compare.pairs import IN_PROCESS_STEP_LEAD_S
from robot_controller.experiments.reporting import pyplot
from robot_controller.experiments.step import STEP_AFTER_S


def render_compare(
    table,
    seeds: int,
    sine_duration_s: float,
    amplitude: float,
    robot: str = "one_dof",
    chosen: Sequence[Contender] | None = None,
    in_process: bool = False,
) -> str:
    names = {c.name: c.description for c in (chosen or CONTENDERS)}
    how = (
        f"the in-process loop (no ROS; the sim-time graph's computation; the step after {IN_PROCESS_STEP_LEAD_S:g} s)"
        if in_process
        else "sim time"
    )
    columns = [
        ("sine_tracking_rms_rad", "sine RMS, true [rad]", "{:.5f}"),
        ("sine_tracking_max_rad", "sine max [rad]", "{:.4f}"),
        ("sine_start_tracking_max_rad", "sine start max [rad]", "{:.4f}"),
        ("step_overshoot_pct", "step overshoot [%]", "{:.2f}"),
        ("step_settling_time_s", "settling 2 % [s]", "{:.3f}"),
        ("step_rise_time_s", "rise 10–90 % [s]", "{:.3f}"),
        ("step_peak_torque_nm", "peak torque [N·m]", "{:.2f}"),
    ]
    lines = [
        "# Controller comparison",
        "",
        f"Robot {robot}, {how}, {seeds} seed(s) each: its default sine for "
        f"{sine_duration_s:g} s (its first 2 s, the start, apart), a {amplitude} rad step of every joint shaped to "
        "the fastest move within 60 rad/s² (slowed if the torque needs it). Figures on the TRUE joint angle, the "
        "worst joint's; mean ± standard deviation over seeds.",
        "",
        "| controller | " + " | ".join(c[1] for c in columns) + " |",
        "|---|" + "---|" * len(columns),
    ]
    for name, row in table.items():
        cells = []
        for key, _, fmt in columns:
            stats = row[key]
            if not np.isfinite(stats["mean"]):
                cells.append(f"never, in {STEP_AFTER_S:g} s" if "settling" in key else "n/a")
            else:
                cells.append(f"{fmt.format(stats['mean'])} ± {fmt.format(stats['std'])}")
        lines.append(f"| **{name}**: {names[name]} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "Targets on the reference arm (one_dof): sine RMS ≤ 0.0015 rad; step overshoot ≤ 2 %, settling ≤ 0.25 s, "
        "|torque| ≤ 10 N·m throughout.",
        "",
    ]
    return "\n".join(lines)


def plot_compare(table, path: Path) -> None:
    plt = pyplot()
    names = list(table)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), constrained_layout=True)
    for ax, key, label, log in (
        (axes[0], "sine_tracking_rms_rad", "sine RMS error, true angle [rad]", True),
        (axes[1], "step_settling_time_s", "step settling time (2 %) [s]", False),
        (axes[2], "step_overshoot_pct", "step overshoot [%]", False),
    ):
        means = [table[n][key]["mean"] for n in names]
        stds = [table[n][key]["std"] for n in names]
        ax.bar(names, means, yerr=stds, capsize=3, color=["#999"] + ["#4c72b0"] * (len(names) - 1))
        if log:
            ax.set_yscale("log")
        ax.set_title(label, fontsize=10)
        ax.tick_params(axis="x", rotation=30)
        ax.grid(alpha=0.3, axis="y")
    fig.savefig(path, dpi=110)
    plt.close(fig)
