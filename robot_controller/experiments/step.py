"""The step response experiment (``robot-controller step``): a real run of a step and its figures."""

from __future__ import annotations

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
