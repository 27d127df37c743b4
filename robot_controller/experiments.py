"""Experiments built on runs: step responses and the controller comparison.

Each run is a real one (launcher → recording → score); these functions only
choose parameters and put figures side by side.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import config as cfg
from robot_controller import launcher, report
from robot_controller.core import metrics

STEP_LEAD_S = 0.5  # time at the start position before the step, s
STEP_AFTER_S = 2.0  # recorded after the step, s


def run_and_score(params: cfg.Params, out: Path, *, duration_s: float, sim_time: bool,
                  single_process: bool = False) -> tuple[dict[str, Any], report.Recording]:
    result = launcher.launch(params, out_dir=out, duration_s=duration_s, sim_time=sim_time,
                             single_process=single_process)
    if result.exit_code != 0:
        raise RuntimeError(f"run in {out} failed: {result.failure}")
    recording = report.read_recording(result.bag_dir)
    values = report.score(recording, nominal_period_s=1.0 / params["pid_controller"]["control_rate_hz"],
                          window_s=duration_s if sim_time else None)
    return values, recording


def step_params(params: cfg.Params, amplitude: float, shaping: str) -> cfg.Params:
    return cfg.merge(params, {"trajectory_planner": {"mode": "step", "amplitude": [amplitude],
                                                     "step_time_s": STEP_LEAD_S, "step_shaping": shaping}})


def step_figures(recording: report.Recording, amplitude: float, offset: float = 0.0) -> dict[str, Any]:
    """Step-response figures on the TRUE angle, timed from the tick where the reference starts to move."""
    s = recording.state
    t = s["time_s"]
    reference = s["reference"][:, 0]
    moved = np.flatnonzero(np.abs(reference - offset) > 1e-9)
    if moved.size == 0:
        raise ValueError("the reference never moved: no step in this recording")
    step_time = t[moved[0]] - (t[1] - t[0])  # the sample before it was still at rest
    true = metrics.true_position_at(t, recording.true_time_s, recording.true_position,
                                    recording.true_velocity)[:, 0]
    ok = np.isfinite(true)
    figures = metrics.step_metrics(t[ok], true[ok], initial=offset, target=offset + amplitude, step_time_s=step_time,
                                   torque=s["command"][ok & (t >= step_time), 0])
    figures["step_time_s"] = float(step_time - t[0])
    return figures


def plot_step(recording: report.Recording, path: Path, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = recording.state
    t = s["time_s"] - s["time_s"][0]
    true = metrics.true_position_at(s["time_s"], recording.true_time_s, recording.true_position,
                                    recording.true_velocity)
    fig, (ax_q, ax_u) = plt.subplots(2, 1, figsize=(9, 6), sharex=True, constrained_layout=True)
    ax_q.plot(t, s["reference"][:, 0], "k--", label="reference")
    ax_q.plot(t, true[:, 0], label="true")
    ax_q.plot(t, s["measured"][:, 0], ".", ms=2, alpha=0.4, label="estimate the law used")
    ax_q.set_ylabel("position [rad]")
    ax_u.plot(t, s["command"][:, 0], label="command")
    ax_u.plot(t, s["feedforward"][:, 0], lw=0.8, label="feedforward")
    ax_u.axhline(10, color="r", lw=0.6)
    ax_u.axhline(-10, color="r", lw=0.6)
    ax_u.set_ylabel("torque [N·m]")
    ax_u.set_xlabel("time [s]")
    for ax in (ax_q, ax_u):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(title)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def step(params: cfg.Params, out: Path, *, amplitude: float, shaping: str, sim_time: bool, seed: int
         ) -> dict[str, Any]:
    params = step_params(params, amplitude, shaping)
    params["sensor_node"]["seed"] = seed
    values, recording = run_and_score(params, out, duration_s=STEP_LEAD_S + STEP_AFTER_S, sim_time=sim_time)
    values.update(step_figures(recording, amplitude))
    values.update({"amplitude_rad": amplitude, "step_shaping": shaping, "seed": seed,
                   "clock": "sim_lockstep" if sim_time else "wall"})
    report.write_metrics(out / "metrics.json", values)
    plot_step(recording, out / "step.png", f"{amplitude} rad step ({shaping}), seed {seed}")
    return values


@dataclass(frozen=True)
class Contender:
    name: str
    description: str
    preset: str
    overrides: dict[str, Any]


CONTENDERS = (
    Contender("seed", "the tutorial's controller as written", "seed", {}),
    Contender("pid", "PID, derivative on velocity error", "default",
              {"controller_type": "pid", "feedforward": "none", "estimator": "none"}),
    Contender("pid_ff", "PID + model feedforward", "default",
              {"controller_type": "pid", "feedforward": "full", "estimator": "none"}),
    Contender("pid_ff_kf", "PID + feedforward + Kalman filter", "default",
              {"controller_type": "pid", "feedforward": "full", "estimator": "kalman"}),
    Contender("lqr", "LQR + feedforward + Kalman filter (default)", "default",
              {"controller_type": "lqr", "feedforward": "full", "estimator": "kalman"}),
)
COMPARED = {"sine": ("tracking_rms_rad", "tracking_max_rad"),
            "step": ("overshoot_pct", "settling_time_s", "rise_time_s", "peak_torque_nm", "steady_state_error_rad")}


def compare(out: Path, *, seeds: int, sine_duration_s: float, amplitude: float,
            progress=print) -> dict[str, dict[str, dict[str, float]]]:
    """Every contender on the sine and on the step, ``seeds`` seeds each, in sim-time lockstep."""
    out.mkdir(parents=True, exist_ok=True)
    table: dict[str, dict[str, dict[str, float]]] = {}
    for contender in CONTENDERS:
        base = cfg.load_stack(contender.preset)
        base = cfg.merge(base, {"pid_controller": contender.overrides})
        rows: dict[str, list[float]] = {}
        for seed in range(seeds):
            progress(f"{contender.name}: seed {seed}")
            params = cfg.merge(base, {"sensor_node": {"seed": seed}})
            sine, _ = run_and_score(params, out / contender.name / f"sine_{seed}", duration_s=sine_duration_s,
                                    sim_time=True)
            figures = step(base, out / contender.name / f"step_{seed}", amplitude=amplitude, shaping="min_time",
                           sim_time=True, seed=seed)
            for key in COMPARED["sine"]:
                rows.setdefault(f"sine_{key}", []).append(sine[key])
            for key in COMPARED["step"]:
                rows.setdefault(f"step_{key}", []).append(figures[key])
        table[contender.name] = {key: {"mean": float(np.mean(v)), "std": float(np.std(v)),
                                       "min": float(np.min(v)), "max": float(np.max(v))} for key, v in rows.items()}
    report.write_metrics(out / "compare.json", table)
    (out / "compare.md").write_text(render_compare(table, seeds, sine_duration_s, amplitude))
    plot_compare(table, out / "compare.png")
    return table


def render_compare(table, seeds: int, sine_duration_s: float, amplitude: float) -> str:
    names = {c.name: c.description for c in CONTENDERS}
    columns = [("sine_tracking_rms_rad", "sine RMS, true [rad]", "{:.5f}"),
               ("sine_tracking_max_rad", "sine max [rad]", "{:.4f}"),
               ("step_overshoot_pct", "step overshoot [%]", "{:.2f}"),
               ("step_settling_time_s", "settling 2 % [s]", "{:.3f}"),
               ("step_rise_time_s", "rise 10–90 % [s]", "{:.3f}"),
               ("step_peak_torque_nm", "peak torque [N·m]", "{:.2f}")]
    lines = [f"# Controller comparison", "",
             f"Reference scenario, sim-time lockstep, {seeds} seed(s) each: sine 1 rad 0.5 Hz for "
             f"{sine_duration_s:g} s (2 s warm-up), {amplitude} rad step shaped to the fastest move within "
             f"60 rad/s². Figures on the TRUE joint angle; mean ± standard deviation over seeds.", "",
             "| controller | " + " | ".join(c[1] for c in columns) + " |",
             "|---|" + "---|" * len(columns)]
    for name, row in table.items():
        cells = []
        for key, _, fmt in columns:
            stats = row[key]
            if not np.isfinite(stats["mean"]):
                cells.append(f"never, in {STEP_AFTER_S:g} s" if "settling" in key else "n/a")
            else:
                cells.append(f"{fmt.format(stats['mean'])} ± {fmt.format(stats['std'])}")
        lines.append(f"| **{name}**: {names[name]} | " + " | ".join(cells) + " |")
    lines += ["", "Targets (issue 4): sine RMS ≤ 0.0015 rad; step overshoot ≤ 2 %, settling ≤ 0.25 s, "
              "|torque| ≤ 10 N·m throughout.", ""]
    return "\n".join(lines)


def plot_compare(table, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(table)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), constrained_layout=True)
    for ax, key, label, log in ((axes[0], "sine_tracking_rms_rad", "sine RMS error, true angle [rad]", True),
                                (axes[1], "step_settling_time_s", "step settling time (2 %) [s]", False),
                                (axes[2], "step_overshoot_pct", "step overshoot [%]", False)):
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
