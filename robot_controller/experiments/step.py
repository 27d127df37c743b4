"""Seeded runs of the real graph and what they show: the step response experiment (``robot-controller step``), a
step's figures, and the sim-time runs the exercises and ``tune`` make, a step's or a sine's, with joint 1's trace
(:class:`Response`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.core import metrics
from robot_controller.core.errors import RunFailed
from robot_controller.experiments.reporting import label_axes, pyplot, save
from robot_controller.runner import launcher, plan
from robot_controller.runner.options import RunOptions
from robot_controller.scoring import plots, report, scored_run

STEP_LEAD_S = 0.5  # time at the start position before the step, s
STEP_AFTER_S = 2.0  # recorded after the step, s
#: The sensor's noise seed of every run: the same seed, the same figures.
SEED = 0


def run_and_score(
    params: cfg.Params, out: Path, *, duration_s: float, sim_time: bool, domain_id: int | None = None
) -> tuple[dict[str, Any], report.Recording]:
    """A run of ``params`` checked whole, then launched, recorded and scored (:func:`run_checked`)."""
    return run_checked(plan.check(params, RunOptions(duration_s, sim_time=sim_time, domain_id=domain_id)), out)


def run_checked(checked: plan.CheckedRun, out: Path) -> tuple[dict[str, Any], report.Recording]:
    """Launch a checked run into ``out``; its figures and facts (:func:`scored_run.score_launched`) and recording."""
    result = launcher.launch(checked, out)
    result.raise_if_interrupted()
    if result.exit_code != 0:
        raise RunFailed(f"run in {out} failed: {result.failure}")
    scored = scored_run.score_launched(checked, result)
    return scored.metrics, scored.recording


def step_params(params: cfg.Params, amplitude: float, shaping: str) -> cfg.Params:
    planner = {"mode": "step", "amplitude": [amplitude], "step_time_s": STEP_LEAD_S, "step_shaping": shaping}
    return cfg.merge(params, {"trajectory_planner": planner})


def step_figures(
    recording: report.Recording,
    amplitude: float,
    offset: float | np.ndarray = 0.0,
    after_s: float | None = STEP_AFTER_S,
) -> dict[str, Any]:
    """:func:`tick_step_figures` of a recording."""
    s = recording.state
    return tick_step_figures(
        s["time_s"], s["reference"], recording.true_at_ticks(), s["command"], amplitude, offset, after_s
    )


def tick_step_figures(
    t: np.ndarray,
    reference: np.ndarray,
    true: np.ndarray,
    command: np.ndarray,
    amplitude: float,
    offset: float | np.ndarray = 0.0,
    after_s: float | None = None,
) -> dict[str, Any]:
    """Step-response figures on the TRUE angle at each tick, from the tick where the reference starts to move,
    over the ``after_s`` s after it (None: to the end; a recording runs on while the nodes stop, a different
    time each run); on a chain, the worst joint's, with ``<figure>_per_joint``.

    :param amplitude: rad, every joint's step from its ``offset`` (rad, one or one per joint)
    :raises ValueError: the run holds no step
    """
    joint_count = reference.shape[1]
    offsets = np.broadcast_to(np.asarray(offset, dtype=float), (joint_count,))
    # The step starts after the last sample at rest (the reference may first blend in from where the joint was).
    at_rest = np.flatnonzero(np.all(np.abs(reference - offsets) <= 1e-9, axis=1))
    if at_rest.size == 0:
        raise ValueError("no sample at rest before the step: the recording misses the run's start")
    if at_rest[-1] == len(t) - 1:
        raise ValueError("the reference never moved: no step in this recording")
    step_time = t[at_rest[-1]]
    ok = np.all(np.isfinite(true), axis=1)
    if after_s is not None:
        ok &= t < step_time + after_s - 1e-9
    per_joint = [
        metrics.step_metrics(
            t[ok],
            true[ok, j],
            initial=offsets[j],
            target=offsets[j] + amplitude,
            step_time_s=step_time,
            torque=command[ok & (t >= step_time), j],
        )
        for j in range(joint_count)
    ]
    figures: dict[str, Any] = dict(per_joint[0])
    if joint_count > 1:
        for key in per_joint[0]:
            values = [joint[key] for joint in per_joint]
            figures[key] = max(values, key=lambda value: abs(value) if np.isfinite(value) else np.inf)
            figures[f"{key}_per_joint"] = values
    figures["step_time_s"] = float(step_time - t[0])
    return figures


def plot_step(
    recording: report.Recording, path: Path, title: str, limit_nm: np.ndarray | None = None, units: list[str] = ()
) -> None:
    """Reference, true position and command of each joint; ``units``: each joint's ``"rad"`` (default) or ``"m"``."""
    plt = pyplot()
    s = recording.state
    t = s["time_s"] - s["time_s"][0]
    true = recording.true_at_ticks()
    fig, (ax_q, ax_u) = plt.subplots(2, 1, figsize=(9, 6), sharex=True, constrained_layout=True)
    joint_count = s["reference"].shape[1]
    units = list(units) or ["rad"] * joint_count
    for j in range(joint_count):
        name = "" if joint_count == 1 else f"joint {j + 1}{' [m]' if units[j] == 'm' else ''} "
        ax_q.plot(t, s["reference"][:, j], "k--", lw=0.8, label=f"{name}reference" if j == 0 else None)
        ax_q.plot(t, true[:, j], label=f"{name}true")
        ax_u.plot(t, s["command"][:, j], label=f"{name}command")
        if joint_count == 1:
            ax_q.plot(t, s["measured"][:, 0], ".", ms=2, alpha=0.4, label="estimate the law used")
            ax_u.plot(t, s["feedforward"][:, 0], lw=0.8, label="feedforward")
    position, _, effort = plots.headings(units)
    label_axes(ax_q, ylabel=position)
    if limit_nm is not None:
        for value in np.unique(np.atleast_1d(limit_nm)):
            ax_u.axhline(value, color="r", lw=0.6)
            ax_u.axhline(-value, color="r", lw=0.6)
    label_axes(ax_u, "time [s]", effort)
    save(fig, path, title)


def check_step(
    params: cfg.Params, *, amplitude: float, shaping: str, sim_time: bool, seed: int, domain_id: int | None = None
) -> plan.CheckedRun:
    """The step run of ``params`` checked whole, before anything is written or started (without ``sim_time``
    in the paced world, as ``run``)."""
    params = step_params(params, amplitude, shaping)
    params["sensor_node"]["seed"] = seed
    options = RunOptions(STEP_LEAD_S + STEP_AFTER_S, sim_time=sim_time, paced=not sim_time, domain_id=domain_id)
    return plan.check(params, options)


def step_response(checked: plan.CheckedRun, out: Path, *, amplitude: float, shaping: str) -> dict[str, Any]:
    """Run the step :func:`check_step` checked; its figures, also in ``metrics.json`` and ``step.png``."""
    params = checked.params
    seed = params["sensor_node"]["seed"]
    values, recording = run_checked(checked, out)
    values.update(step_figures(recording, amplitude, np.asarray(params["trajectory_planner"]["offset"], float)))
    values.update(amplitude_rad=amplitude, step_shaping=shaping, seed=seed)
    report.write_metrics(out / "metrics.json", values)
    limit_nm = np.asarray(params["motor_node"]["torque_max"], float)
    plot_step(
        recording, out / "step.png", f"{amplitude} rad step ({shaping}), seed {seed}", limit_nm, values["joint_units"]
    )
    return values


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
