"""Automatic gain design (``robot-controller tune``): the gains that track the
sine best on the configured arm and controller, among those that keep the
discrete loop robust, then checked on the real graph.

1. **Search** on the fast in-process batch harness (``core.batch``: the arm's
   analytic model under the controller's own PID code, thousands of gain sets
   at once): Latin-hypercube samples of the gains over a wide log-scaled box,
   then rounds of samples around the best so far, each round narrower. What
   is searched depends on ``controller_type``: for ``pid``, Kp, Ki and Kd; for
   ``lqr``, the state weights ``lqr_q`` (the design then gives the gains; only
   the ratio of ``lqr_q`` to ``lqr_r`` matters, so ``lqr_r`` keeps its value).
   (``search``; what is searched and the objective: ``problem``.)
2. **Robustness first**: a gain set is simulated only if the sampled loop
   (``core.lqr.discretise``, the feedback on ``[∫e, e, ė]``) has a gain
   margin ≥ 6 dB, a phase margin ≥ 45°, survives ≥ 2 control periods of
   extra delay (``core.robustness``, ``core.lqr.delay_margin_periods``) and
   has no lower gain limit (``UNCONDITIONALLY_STABLE``); and its slowest
   pole's time constant is at most ``MAX_TIME_CONSTANT_S`` (integral action
   that removes a steady load within seconds: the sine alone would not ask
   for it). (``margins``.)
3. **Objective**: the RMS of (reference − true angle) on the sine (the
   planner's amplitude, frequency and offset; 1 rad 0.5 Hz by default), after
   the 2 s warm-up, with the sensor's noise, the torque limit and the
   configured feedforward, anti-windup and derivative source.
4. **Check** before and after on the real graph: one seeded lockstep sine
   run each (five processes, ``step.run_and_score``). (``verify``.)

Writes ``tuned.yaml`` (a ROS 2 parameter file overlay for ``--config``),
``tune.json`` (flat: gains, margins, batch and real RMS before and after) and
``report.md`` (``report``).

The batch simulates the analytic arm with the controller's PID code, the
sensor's noise (the same noise for every gain set: common random numbers),
the torque limit, the feedforward and, when configured, the Kalman filter.
What it does not model: the planner's rate and the controller's reference
hold (the reference is evaluated at every tick), reference extrapolation,
latency compensation and MuJoCo's own arm. The real runs show what these
change.

This module is the verb itself (:func:`tune`), and keeps every part's public
names importable from here.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.experiments.autotune.margins import (
    MAX_TIME_CONSTANT_S,
    MIN_DELAY_PERIODS,
    MIN_GAIN_MARGIN_DB,
    MIN_PHASE_MARGIN_DEG,
    UNCONDITIONALLY_STABLE,
    describe_margins,
)
from robot_controller.experiments.autotune.problem import LQR_BOX, PID_BOX, SEED, Problem, batch_tracking_rms
from robot_controller.experiments.autotune.report import plot, report_text, yaml_header
from robot_controller.experiments.autotune.search import (
    Candidates,
    Plan,
    SearchResult,
    latin_hypercube,
    plan,
    search,
    steps,
)
from robot_controller.experiments.autotune.verify import real_graph
from robot_controller.scoring import report

__all__ = [
    "LQR_BOX",
    "MAX_TIME_CONSTANT_S",
    "MIN_DELAY_PERIODS",
    "MIN_GAIN_MARGIN_DB",
    "MIN_PHASE_MARGIN_DEG",
    "PID_BOX",
    "SEED",
    "UNCONDITIONALLY_STABLE",
    "Candidates",
    "Plan",
    "Problem",
    "SearchResult",
    "batch_tracking_rms",
    "describe_margins",
    "latin_hypercube",
    "plan",
    "search",
    "steps",
    "tune",
]


def tune(
    params: cfg.Params, out: Path, *, quick: bool = False, progress: Callable[[str], None] = print, seed: int = SEED
) -> dict[str, Any]:
    """Search, write ``tuned.yaml``, run before and after on the real graph, write ``tune.json`` and ``report.md``."""
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    settings = plan(quick)
    result = search(params, quick=quick, progress=progress, seed=seed)
    problem = result.problem
    search_s = time.perf_counter() - started
    before_gains = np.array([problem.law.kp[0], problem.law.ki[0], problem.law.kd[0]], dtype=float)
    before_after = problem.tracking_rms(np.vstack([before_gains, result.best_gains]), settings.duration_s, seed)
    overlay = problem.overlay(result.best_values)
    tuned_path = out / "tuned.yaml"
    cfg.write_params_file({"pid_controller": overlay}, tuned_path)
    tuned_path.write_text(yaml_header(problem, result) + tuned_path.read_text())
    tuned_params = cfg.merge(params, {"pid_controller": overlay})

    values: dict[str, Any] = {
        "quick": int(quick),
        "seed": seed,
        "controller_type_lqr": int(problem.controller_type == "lqr"),
        "search_wall_s": search_s,
        "candidates_evaluated": result.evaluated,
        "candidates_robust": result.robust,
        "batch_duration_s": settings.duration_s,
        "min_gain_margin_db": MIN_GAIN_MARGIN_DB,
        "min_phase_margin_deg": MIN_PHASE_MARGIN_DEG,
        "min_delay_margin_periods": MIN_DELAY_PERIODS,
    }
    for name, gains, searched in (
        ("before", before_gains, 10.0 ** problem.current_log_params()),
        ("after", result.best_gains, result.best_values),
    ):
        values.update({f"{name}_kp": gains[0], f"{name}_ki": gains[1], f"{name}_kd": gains[2]})
        if problem.controller_type == "lqr":
            for key, value in zip(("q_integral", "q_position", "q_velocity"), searched, strict=True):
                values[f"{name}_lqr_{key}"] = float(value)
            values[f"{name}_lqr_r"] = problem.lqr_r
        for key, value in describe_margins(problem, gains).items():
            values[f"{name}_{key}"] = value
    values["batch_rms_before_rad"], values["batch_rms_after_rad"] = (float(v) for v in before_after)

    values.update(real_graph(params, tuned_params, out, duration_s=settings.real_s, seed=seed, progress=progress))
    values["wall_s"] = time.perf_counter() - started
    report.write_metrics(out / "tune.json", values)
    plot(out / "tune.png", result, before_gains)
    (out / "report.md").write_text(report_text(values, problem, result, quick))
    return report.json_safe(values)
