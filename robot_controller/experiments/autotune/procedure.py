"""``robot-controller tune``: the best-tracking robust gains for any law (``analytic`` for a built-in
one, ``blackbox`` for one's own); writes ``tuned.yaml``, ``tune.json``, ``report.md`` and ``tune.png``."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from robot_controller import parameters as cfg
from robot_controller.core.laws import registry
from robot_controller.experiments.autotune import analytic, analytic_report, blackbox, blackbox_report
from robot_controller.experiments.autotune.search import SEED, search
from robot_controller.scoring import report


def _kind(controller_type: str):
    """The problem class and its report module for a law: analytic for the built-in ones."""
    if registry.is_builtin(controller_type.strip()):
        return analytic.AnalyticProblem, analytic, analytic_report
    return blackbox.BlackBoxProblem, blackbox, blackbox_report


def steps(quick: bool = False, controller_type: str = "pid") -> int:
    """How many times :func:`tune` calls ``progress``: each search round, then the checks."""
    problem_class = _kind(controller_type)[0]
    return 1 + len(problem_class.plan(quick).rounds) + problem_class.check_steps


def tune(
    params: cfg.Params, out: Path, *, quick: bool = False, progress: Callable[[str], None] = print, seed: int = SEED
) -> dict[str, Any]:
    """Search, check before and after, write ``tuned.yaml``, ``tune.json``, ``report.md`` and ``tune.png``.

    :raises RuntimeError: no candidate met the margins
    """
    started = time.perf_counter()
    problem_class, figures, writer = _kind(params["pid_controller"]["controller_type"])
    problem = problem_class(params)
    plan = problem.plan(quick)
    out.mkdir(parents=True, exist_ok=True)
    result = search(problem, plan, progress=progress, seed=seed)
    search_s = time.perf_counter() - started
    tuned_path = out / "tuned.yaml"
    cfg.write_params_file({"pid_controller": problem.tuned_overlay(result.best_values)}, tuned_path)
    use = "# Use over the same preset and files it was tuned with: "
    use += "robot-controller run [--preset P] [--config F ...] --config tuned.yaml\n"
    tuned_path.write_text(writer.yaml_header(problem, result) + use + tuned_path.read_text())
    values = {"quick": int(quick), "seed": seed, "search_wall_s": search_s}
    values.update(candidates_evaluated=result.evaluated, candidates_robust=result.robust)
    values |= figures.before_after(problem, result, plan, seed=seed, out=out, progress=progress)
    values["wall_s"] = time.perf_counter() - started
    report.write_metrics(out / "tune.json", values)
    writer.plot(out / "tune.png", result)
    (out / "report.md").write_text(writer.report_text(values, problem, result, quick))
    return report.json_safe(values)
