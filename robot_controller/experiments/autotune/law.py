"""``robot-controller tune --controller SPEC`` for a law of one's own (a plugin):
its parameters declared ``gain=True`` searched within their ``minimum`` and
``maximum``, on the in-process loop, under the built-in tune's margins where a
black box allows them.

A plugin law is a black box: there is no transfer function to take margins of,
and the batch harness (``core.batch``) runs the built-in PID only. So every
candidate runs the in-process loop (the lockstep graph's computation: MuJoCo
arm, sensor noise, the law), and the margins are measured there, as pushes
that must die away:

- **Objective**: the sine's tracking RMS (reference − true angle, after the 2 s
  warm-up) with the configured stack (its estimator included) and the sensor's
  noise; every candidate meets the same noise draws.
- **Robustness**, the built-in's margins (``margins``) as a black box shows them.
  A short push (``PUSH_FRACTION`` of each joint's torque limit for
  ``PUSH_PERIODS`` control periods, at ``PUSH_AT_S`` on the sine) is given to
  the loop, and the same run unpushed (the same sensor noise) is subtracted:
  what is left is the push's own effect (as in ``exercise disturbance``). A
  case passes if that effect has died down to ``DECAY_FRACTION`` (e⁻³) of its
  peak, or to ``DECAY_FLOOR_RAD``, by ``3 × MAX_TIME_CONSTANT_S`` after the
  push; neither run's torque reached the limit after the warm-up (an unstable
  loop swings into the limit, and then both runs swing alike); and the law did
  not fault. These runs are the configured loop, sensor noise and Kalman filter
  included, without the filter's disturbance observer (:data:`WITHOUT_OBSERVER`).
  The cases, checked in this order:

  * *delay*: the readings ``MIN_DELAY_PERIODS`` (2) control periods late and
    stamped on arrival, so nothing can compensate them: the delay margin;
  * *nominal*: as configured: the slowest closed-loop pole's time constant
    within ``MAX_TIME_CONSTANT_S`` (1 s), roughly;
  * *gain up*: the drive applies 2× (+6 dB) the command: the gain margin;
  * *gain down*: ½× (−6 dB): a loop that a lower gain (saturation) destabilises.

  Not checked: the phase margin (a black box has no crossover to measure it
  at; the delay case bounds the phase lost to delay), and gains beyond the
  two points ±6 dB. A candidate is checked only if it tracks better than the
  best robust one so far; the search keeps the best that passes.
- **Search**: a Latin hypercube over the declared ranges (log-scaled where a
  range is not negative and spans a decade or more; one from 0 from
  ``FROM_ZERO`` of its maximum), then rounds of samples around the best robust
  ones, narrower each round.
- **Check**: before and after, on another noise seed and a longer run; and the
  delay margin measured in whole periods (the most delay each survives).

Writes ``tuned.yaml`` (``controller_type`` and the ``law.NAME`` values, for
``--config``), ``tune.json`` (flat) and ``report.md``, ``tune.png``.

The parts: what is searched and the cases (``law_problem``), the search
(``law_search``) and what is written besides the values (``law_report``);
this module is the procedure itself (:func:`tune_law`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.experiments.autotune.law_problem import CASES, CHECK_SEED, GAIN_FACTOR, LawProblem
from robot_controller.experiments.autotune.law_report import plot_candidates, report_markdown, yaml_header
from robot_controller.experiments.autotune.law_search import plan, search, steps
from robot_controller.experiments.autotune.margins import MAX_TIME_CONSTANT_S, MIN_DELAY_PERIODS
from robot_controller.experiments.autotune.problem import SEED
from robot_controller.scoring import report


def describe(problem: LawProblem, values: np.ndarray, duration_s: float, check_s: float) -> dict[str, Any]:
    """Everything the report says of one set of values: each case, the delay margin, the RMS."""
    out: dict[str, Any] = {k.name: float(v) for k, v in zip(problem.knobs, values, strict=True)}
    meets = True
    for case in CASES:
        decay = problem.push_decay(values, case)
        out.update({f"{case.name}_{key}": value for key, value in decay.items() if key != "ok"})
        out[f"{case.name}_ok"] = int(decay["ok"])
        meets &= decay["ok"]
    out["meets_constraints"] = int(meets)
    out["delay_margin_periods"] = problem.delay_margin(values)
    out["search_rms_rad"] = problem.tracking_rms(values, duration_s, SEED)
    out["check_rms_rad"] = problem.tracking_rms(values, check_s, CHECK_SEED)
    return out


def tune_law(
    params: cfg.Params, out: Path, *, quick: bool = False, progress: Callable[[str], None] = print, seed: int = SEED
) -> dict[str, Any]:
    """Search, then check before and after; write ``tuned.yaml``, ``tune.json``, ``report.md`` and ``tune.png``."""
    started = time.perf_counter()
    problem = LawProblem(params)
    settings = plan(quick)
    out.mkdir(parents=True, exist_ok=True)
    result = search(problem, quick=quick, progress=progress, seed=seed)
    search_s = time.perf_counter() - started
    progress(f"check: before and after, {settings.check_s:g} s on noise seed {CHECK_SEED}, and the delay margins")
    before = describe(problem, problem.current(), settings.duration_s, settings.check_s)
    after = describe(problem, result.best_values, settings.duration_s, settings.check_s)
    overlay = {"controller_type": problem.spec} | problem.overlay(result.best_values)
    tuned_path = out / "tuned.yaml"
    cfg.write_params_file({"pid_controller": overlay}, tuned_path)
    tuned_path.write_text(yaml_header(problem, result) + tuned_path.read_text())
    values: dict[str, Any] = {
        "quick": int(quick),
        "seed": seed,
        "check_seed": CHECK_SEED,
        "controller_type": problem.spec,
        "searched": ",".join(k.name for k in problem.knobs),
        "search_wall_s": search_s,
        "candidates_evaluated": result.evaluated,
        "candidates_checked": result.checked,
        "candidates_robust": result.robust,
        "search_duration_s": settings.duration_s,
        "check_duration_s": settings.check_s,
        "min_delay_margin_periods": MIN_DELAY_PERIODS,
        "gain_factor": GAIN_FACTOR,
        "max_time_constant_s": MAX_TIME_CONSTANT_S,
    }
    values |= {f"before_{k}": v for k, v in before.items()} | {f"after_{k}": v for k, v in after.items()}
    values["wall_s"] = time.perf_counter() - started
    report.write_metrics(out / "tune.json", values)
    plot_candidates(out / "tune.png", result, problem.current())
    (out / "report.md").write_text(report_markdown(values, problem, result, quick))
    return report.json_safe(values)


__all__ = ["CASES", "LawProblem", "describe", "plan", "search", "steps", "tune_law"]
