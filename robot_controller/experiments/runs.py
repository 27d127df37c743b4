"""Seeded sim-time runs of the real graph and what they show, as the exercises and ``tune`` use them:
a step's figures, a sine's tracking, one joint's trace (:class:`Response`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.experiments.reporting import label_axes
from robot_controller.experiments.step import run_and_score, step_figures, step_params
from robot_controller.scoring import report

#: The sensor's noise seed of every run: the same seed, the same figures.
SEED = 0


@dataclass
class Response:
    """One sim-time run, as the exercises plot and tabulate it."""

    label: str
    time_s: np.ndarray  #: control ticks, s from the step (step runs) or from the first tick (sine runs)
    reference: np.ndarray  #: rad, the reference the law used
    position: np.ndarray  #: rad, the TRUE joint angle at each tick
    command: np.ndarray  #: N·m
    integral: np.ndarray  #: N·m, the I term
    saturated: np.ndarray  #: bool per tick: the torque limit cut the command
    figures: dict[str, Any] = field(default_factory=dict)
    out: Path | None = None


def run_sim_time(params: cfg.Params, out: Path, duration_s: float) -> tuple[dict[str, Any], report.Recording]:
    """``step.run_and_score`` on sim time; a run that fails is run once more (in ``<out>_retry``):
    a run is deterministic per seed, so one stray failure does not end an exercise of twenty runs."""
    try:
        return run_and_score(params, out, duration_s=duration_s, sim_time=True)
    except RuntimeError as exc:
        print(f"[exercise] WARNING: {exc}; running it once more", flush=True)
        return run_and_score(params, out.with_name(out.name + "_retry"), duration_s=duration_s, sim_time=True)


def store(results: dict[str, Any], prefix: str, figures: dict[str, Any], keys) -> None:
    """``results[f"{prefix}_{key}"]`` for each of ``keys`` from ``figures``."""
    results.update({f"{prefix}_{key}": figures[key] for key in keys})


def _response(
    label: str, recording: report.Recording, start_s: float, figures: dict[str, Any], out: Path, until_s: float
) -> Response:
    """Joint 1's trace from ``start_s`` (s of the recording) until ``until_s`` after it."""
    s = recording.state
    t = s["time_s"] - start_s
    keep = t < until_s - 1e-9
    true = recording.true_at_ticks()
    trace = (s["reference"][keep, 0], true[keep, 0], s["command"][keep, 0], s["i"][keep, 0])
    return Response(label, t[keep], *trace, s["saturated"][keep, 0] > 0.5, figures, out)


def step_run(
    params: cfg.Params,
    out: Path,
    label: str,
    *,
    amplitude: float,
    offset: float = 0.0,
    shaping: str = "none",
    lead_s: float = 0.5,
    after_s: float = 2.0,
    seed: int = SEED,
) -> Response:
    """A step from ``offset`` (the arm at rest there) to ``offset + amplitude`` after ``lead_s``, recorded
    ``after_s`` beyond it, on sim time. Figures on the TRUE angle after the step: ``step.step_figures``',
    ``overshoot_final_pct`` (beyond where the response ends), ``saturated_s`` and ``peak_torque_nm``."""
    start = {"simulator": {"initial_position": [offset]}, "sensor_node": {"seed": seed}}
    planner = {"trajectory_planner": {"offset": [offset], "step_time_s": lead_s}}
    params = cfg.merge(step_params(params, amplitude, shaping), planner | start)
    _, recording = run_sim_time(params, out, lead_s + after_s)
    figures = step_figures(recording, amplitude, offset, after_s)
    response = _response(label, recording, recording.state["time_s"][0] + figures["step_time_s"], figures, out, after_s)
    window = response.time_s >= 0
    period = 1.0 / params["pid_controller"]["control_rate_hz"]
    figures["saturated_s"] = float(np.count_nonzero(response.saturated[window]) * period)
    figures["overshoot_final_pct"] = overshoot_vs_final_pct(response.time_s[window], response.position[window])
    figures["peak_torque_nm"] = float(np.max(np.abs(response.command[window])))
    return response


def overshoot_vs_final_pct(time_s: np.ndarray, position: np.ndarray) -> float:
    """The peak beyond the response's final value (its last 10 %'s mean), in % of the distance travelled."""
    if len(position) < 10:
        return float("nan")
    start, final = float(position[0]), float(np.mean(position[int(0.9 * len(position)) :]))
    travel = final - start
    if abs(travel) < 1e-9:
        return float("nan")
    return max(0.0, float(np.max((position - final) / travel)) * 100.0)


def sine_run(params: cfg.Params, out: Path, label: str, *, duration_s: float, seed: int = SEED) -> Response:
    """The configured planner (the sine, unless the parameters say otherwise) for ``duration_s`` sim s on
    sim time; figures are the run's scores (``tracking_rms_rad`` on the TRUE angle after the warm-up…)."""
    values, recording = run_sim_time(cfg.merge(params, {"sensor_node": {"seed": seed}}), out, duration_s)
    return _response(label, recording, recording.state["time_s"][0], values, out, duration_s)


def sine_params(params: cfg.Params) -> cfg.Params:
    """The reference scenario's sine (1 rad, 0.5 Hz), whatever the planner was set to."""
    defaults = cfg.defaults()["trajectory_planner"]
    keys = ("mode", "amplitude", "frequency_hz", "offset")
    return cfg.merge(params, {"trajectory_planner": {key: defaults[key] for key in keys}})


def plot_steps(
    ax, responses: list[Response], *, band: tuple[float, float] | None = None, reference: bool = True, title: str = ""
) -> None:
    """The true angle of each response against time since the step; ``band`` (low, high) shaded."""
    if reference and responses:
        first = responses[0]
        ax.plot(first.time_s, first.reference, "k--", lw=0.9, label="reference")
    for response in responses:
        ax.plot(response.time_s, response.position, lw=1.2, label=response.label)
    if band is not None:
        ax.axhspan(*band, color="0.88", lw=0, zorder=0)
    label_axes(ax, "time since the step [s]", "joint angle, true [rad]", legend=7)
    if title:
        ax.set_title(title, fontsize=10)
