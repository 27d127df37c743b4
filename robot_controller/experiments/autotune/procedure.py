"""``robot-controller tune``: the best-tracking robust gains for any law (``analytic`` for a built-in
one, ``blackbox`` for one's own) on one joint, each joint's LQR weight on a chain (``chain``); verified against the
gains in force on the real graph, and written as ``tuned.yaml`` only if it beats them (``verification``), with
``tune.json`` and ``report.md``."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from robot_controller import parameters as cfg
from robot_controller.core.laws import registry
from robot_controller.experiments.autotune import analytic, analytic_report, blackbox, blackbox_report, chain
from robot_controller.experiments.autotune.search import SEED, search
from robot_controller.experiments.autotune.verification import Verification, verify
from robot_controller.scoring import report


def _kind(controller_type: str):
    """The problem class and its report module for a law: analytic for the built-in ones."""
    if registry.is_builtin(controller_type.strip()):
        return analytic.AnalyticProblem, analytic, analytic_report
    return blackbox.BlackBoxProblem, blackbox, blackbox_report


#: The seeds a design is verified over on the real graph (quick, full), and each run's sim seconds on a chain.
VERIFY_SEEDS = {True: 3, False: 5}
CHAIN_CHECK_S = {True: 6.0, False: 10.0}
USE = (
    "# Use over the same preset and files it was tuned with: "
    "robot-controller run [--preset P] [--config F ...] --config tuned.yaml\n"
)


def steps(quick: bool = False, controller_type: str = "pid", joint_count: int = 1) -> int:
    """How many times :func:`tune` calls ``progress``: the design (each search round, then its checks), then each
    verifying run."""
    verifying = 2 * VERIFY_SEEDS[quick]
    if joint_count > 1 and registry.is_builtin(controller_type.strip()):
        return 1 + verifying
    problem_class = _kind(controller_type)[0]
    return 1 + len(problem_class.plan(quick).rounds) + problem_class.check_steps + verifying


def tune(
    params: cfg.Params,
    out: Path,
    *,
    quick: bool = False,
    progress: Callable[[str], None] = print,
    seed: int = SEED,
    target: str = "tracking",
) -> dict[str, Any]:
    """Design, verify against the gains in force, and write ``tune.json``, ``report.md`` (and ``tune.png`` on one
    joint); ``tuned.yaml`` only when the design is recommended (:mod:`.verification`).

    :raises RuntimeError: no candidate met the margins
    """
    out.mkdir(parents=True, exist_ok=True)
    chain_law = registry.is_builtin(params["pid_controller"]["controller_type"].strip())
    if params["trajectory_planner"]["joint_count"] > 1 and chain_law:
        return _tune_chain(params, out, quick=quick, progress=progress, seed=seed, target=target)
    started = time.perf_counter()
    problem_class, figures, writer = _kind(params["pid_controller"]["controller_type"])
    problem = problem_class(params)
    plan = problem.plan(quick)
    result = search(problem, plan, progress=progress, seed=seed)
    search_s = time.perf_counter() - started
    values = {"quick": int(quick), "seed": seed, "search_wall_s": search_s}
    values.update(candidates_evaluated=result.evaluated, candidates_robust=result.robust)
    values |= figures.before_after(problem, result, plan, seed=seed, out=out, progress=progress)
    overlay = problem.tuned_overlay(result.best_values)
    tuned = cfg.merge(params, {"pid_controller": overlay})
    checked = verify(params, tuned, seeds=_seeds(seed, quick), duration_s=plan.check_s, out=out, progress=progress)
    values |= {f"verification_{key}": value for key, value in checked.as_values().items()}
    header = writer.yaml_header(problem, result)
    _write_if_recommended(checked, overlay, header, out)
    values["wall_s"] = time.perf_counter() - started
    report.write_metrics(out / "tune.json", values)
    writer.plot(out / "tune.png", result)
    (out / "report.md").write_text(writer.report_text(values, problem, result, quick) + _verdict_text(checked))
    return report.json_safe(values)


def _seeds(seed: int, quick: bool) -> tuple[int, ...]:
    return tuple(range(seed, seed + VERIFY_SEEDS[quick]))


def _write_if_recommended(checked: Verification, overlay: dict[str, Any], header: str, out: Path) -> None:
    """``tuned.yaml`` for a recommended design; none (and none left from before) otherwise."""
    tuned_path = out / "tuned.yaml"
    tuned_path.unlink(missing_ok=True)
    if not checked.recommended:
        return
    cfg.write_params_file({"pid_controller": overlay}, tuned_path)
    tuned_path.write_text(header + USE + tuned_path.read_text())


def _verdict_text(checked: Verification) -> str:
    return f"\n## Verified on the real graph\n\n{checked.verdict()[0].upper()}{checked.verdict()[1:]}.\n"


def _tune_chain(
    params: cfg.Params, out: Path, *, quick: bool, progress: Callable[[str], None], seed: int, target: str
) -> dict[str, Any]:
    """Each joint's LQR torque weight for ``target`` (:mod:`.chain`), verified over seeds on the real graph."""
    started = time.perf_counter()
    designs = chain.design_joints(params, target)
    progress(f"designed every joint for {target}: {chain.TARGET_TEXT[target]}")
    lines = chain.design_lines(designs)
    for line in lines:
        print(f"tune: {line}", flush=True)
    overlay = chain.overlay(designs)
    tuned = params if chain.in_force(params, designs) else cfg.merge(params, {"pid_controller": overlay})
    duration_s = CHAIN_CHECK_S[quick]
    checked = verify(params, tuned, seeds=_seeds(seed, quick), duration_s=duration_s, out=out, progress=progress)
    values: dict[str, Any] = {"quick": int(quick), "seed": seed, "target": target, "joint_count": len(designs)}
    for d in designs:
        values.update({f"{d.name}_lqr_r": d.lqr_r, f"{d.name}_lqr_r_in_force": d.in_force_r, f"{d.name}_kp": d.kp})
        values.update({f"{d.name}_kd": d.kd, f"{d.name}_delay_margin_periods": d.delay_margin_periods})
        values.update({f"{d.name}_delay_margin_in_force_periods": d.in_force_margin_periods})
        values.update({f"{d.name}_noise_torque_nm": d.noise_torque_nm, f"{d.name}_found": int(d.found)})
    values |= {f"verification_{key}": value for key, value in checked.as_values().items()}
    header = f"# Automatic gain design, every joint for {target}: {chain.TARGET_TEXT[target]}\n# " + "\n# ".join(lines)
    _write_if_recommended(checked, overlay, header + "\n# " + checked.verdict() + "\n", out)
    values["wall_s"] = time.perf_counter() - started
    report.write_metrics(out / "tune.json", values)
    text = [
        "# Automatic gain design: every joint",
        "",
        f"Target `{target}`: {chain.TARGET_TEXT[target]}, and the torque its feedback makes of the sensor's noise "
        "within its share of the joint's torque limit. Each joint's LQR torque weight `lqr_r` is chosen on its own "
        "(the other joints at theirs), its margin judged through the filter and the disturbance observer as the "
        "controller judges it at start.",
        "",
        *(f"- {line}" for line in lines),
        "",
    ]
    (out / "report.md").write_text("\n".join(text) + _verdict_text(checked))
    return report.json_safe(values)
