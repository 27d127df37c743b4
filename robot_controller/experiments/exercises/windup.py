"""Exercise 3, "Remove anti-windup": the tutorial's controller with the torque limited to 2 N·m, a
1 rad jump the arm cannot follow at once, and every anti-windup mode side by side."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.blocks import spec
from robot_controller.core.laws.pid import AntiWindup
from robot_controller.experiments import reporting
from robot_controller.experiments.reporting import Progress, cells, pyplot, save, table, write_report, write_results
from robot_controller.experiments.step import SEED, Response, plot_steps, step_run, store

PRESET = "tutorial"
TORQUE_MAX_NM = 2.0
STEP_RAD = 1.0
#: Where the step starts: 1 rad above horizontal, where gravity needs 1.3 of the 2 N·m. (At 0 rad, gravity
#: alone needs 2.45 N·m: the arm could not even hold there.) The step lifts it over the top to 2 rad.
OFFSET_RAD = 1.0
LEAD_S = 0.5
MODES = tuple(mode.value for mode in AntiWindup)  # none, clamp, back_calculation, conditional_integration
#: What each mode does, for the report.
MEANING = {
    "none": "the integral grows for as long as there is an error, saturated or not",
    "clamp": "|∫e dt| is clamped so that the I term alone stays within the torque limit",
    "back_calculation": "what the limit cut off is fed back into the I term (time constant 0.1 s)",
    "conditional_integration": "the integral stops while the output is saturated and the error pushes further out",
    "clamp_tutorial": "the tutorial's clamp, |∫e dt| ≤ 10 rad·s: an I term of up to 100 N·m",
}


def _plan(quick: bool) -> dict[str, Any]:
    return {"after_s": 2.0 if quick else 3.0, "modes": MODES if quick else (*MODES, "clamp_tutorial")}


def steps(quick: bool = False) -> int:
    return len(_plan(quick)["modes"])


def mode_params(base: cfg.Params, mode: str) -> cfg.Params:
    """The tutorial's controller with ``torque_max`` 2 N·m (controller and motor) and anti-windup ``mode``."""
    ki = float(base["pid_controller"]["ki"][0])
    overrides: dict[str, Any] = {"torque_max": [TORQUE_MAX_NM], "anti_windup": mode}
    if mode == "clamp":
        overrides["integral_limit"] = [TORQUE_MAX_NM / ki]  # |Ki ∫e dt| ≤ torque_max
    elif mode == "clamp_tutorial":
        overrides["anti_windup"] = "clamp"  # with the preset's integral_limit, the tutorial's ±10 rad·s
    planner: dict[str, Any] = {}
    if cfg.has("trajectory_planner", "torque_max"):  # the planner checks its path against the motor's limit
        planner["torque_max"] = [TORQUE_MAX_NM]
    if cfg.has("trajectory_planner", "feasibility"):
        planner["feasibility"] = "ignore"  # a jump the arm cannot follow at once is the point here
    motor = {"torque_max": [TORQUE_MAX_NM]}
    return cfg.merge(base, {"pid_controller": overrides, "motor_node": motor, "trajectory_planner": planner})


def run(out: Path, *, quick: bool = False, progress: Progress = print, seed: int = SEED) -> dict[str, Any]:
    out.mkdir(parents=True, exist_ok=True)
    plan = _plan(quick)
    base = cfg.load_stack(PRESET)
    pid = base["pid_controller"]
    results: dict[str, Any] = {"quick": int(quick), "seed": seed, "torque_max_nm": TORQUE_MAX_NM, "step_rad": STEP_RAD}
    results.update(offset_rad=OFFSET_RAD, kp=pid["kp"][0], ki=pid["ki"][0], kd=pid["kd"][0])
    step = {"amplitude": STEP_RAD, "offset": OFFSET_RAD, "lead_s": LEAD_S, "after_s": plan["after_s"], "seed": seed}
    responses: list[Response] = []
    for mode in plan["modes"]:
        progress(f"anti-windup {mode}")
        response = step_run(mode_params(base, mode), out / mode, mode, **step)
        after = response.time_s >= 0
        response.figures["integral_max_nm"] = float(np.max(response.integral[after]))
        response.figures["integral_min_nm"] = float(np.min(response.integral[after]))
        responses.append(response)
        keys = "overshoot_pct settling_time_s saturated_s rise_time_s steady_state_error_rad integral_max_nm"
        store(results, mode, response.figures, (*keys.split(), "integral_min_nm", "peak_torque_nm"))
    results = write_results(out, results)
    _plot(out / "windup.png", responses)
    write_report(out, _report(results, plan, responses, quick))
    return results


def _plot(path: Path, responses: list[Response]) -> None:
    plt = pyplot()
    fig, (ax_q, ax_i, ax_u) = plt.subplots(3, 1, figsize=(10, 10), sharex=True, constrained_layout=True)
    target = OFFSET_RAD + STEP_RAD
    plot_steps(
        ax_q,
        responses,
        band=(target - 0.02 * STEP_RAD, target + 0.02 * STEP_RAD),
        title=f"{STEP_RAD:g} rad step from {OFFSET_RAD:g} rad, torque limited to ±{TORQUE_MAX_NM:g} N·m",
    )
    for response in responses:
        ax_i.plot(response.time_s, response.integral, lw=1.1, label=response.label)
        ax_u.plot(response.time_s, response.command, lw=1.0, label=response.label)
    for ax, label in ((ax_i, "integral term I [N·m]"), (ax_u, "command [N·m]")):
        ax.axhline(TORQUE_MAX_NM, color="r", lw=0.6)
        ax.axhline(-TORQUE_MAX_NM, color="r", lw=0.6)
        reporting.label_axes(ax, ylabel=label, legend=7)
    ax_u.set_xlabel("time since the step [s]")
    ax_q.set_xlabel("")
    save(fig, path, "Exercise 3: saturation at 2 N·m, with and without anti-windup (real graph, sim time)")


def _report(results: dict[str, Any], plan: dict[str, Any], responses: list[Response], quick: bool) -> str:
    after = plan["after_s"]
    never = f"not in {after:g} s"
    lines = [
        "# Exercise 3: saturation without anti-windup",
        "",
        "*The tutorial: comment out the np.clip line (its anti-windup). Saturate the motor by setting "
        "torque_max = 2.0. Watch the system overshoot.*",
        "",
        f"The tutorial's controller (Kp {results['kp']:g}, Ki {results['ki']:g}, Kd {results['kd']:g}, no "
        f"feedforward) with the torque limited to {TORQUE_MAX_NM:g} N·m in the controller and in the motor. The "
        f"arm starts at rest at {OFFSET_RAD:g} rad (above horizontal, where holding it against gravity takes "
        f"1.3 N·m of the 2) and the reference jumps by {STEP_RAD:g} rad, over the top to "
        f"{OFFSET_RAD + STEP_RAD:g} rad: far more than the arm can follow at once, so the command sits at the "
        "limit while the arm catches up. One run per anti-windup mode, everything else identical: the whole "
        f"graph as five processes on sim time (sensor seed {results['seed']}), figures on the TRUE "
        f"angle over the {after:g} s after the step." + (" **Quick form**." if quick else ""),
        "",
    ]
    rows = []
    for response in responses:
        mode, prefix = response.label, f"{response.label}_"
        low, high = cells(results, (("integral_min_nm", "{:.2f}"), ("integral_max_nm", "{:.2f}")), prefix)
        figures = (("overshoot_pct", "{:.1f}"), ("settling_time_s", "{:.2f}", never), ("saturated_s", "{:.2f}"))
        end = cells(results, (("steady_state_error_rad", "{:.4f}"),), prefix)
        rows.append([f"**{mode}**: {MEANING[mode]}", *cells(results, figures, prefix), f"{low} … {high}", *end])
    lines += [
        table(
            "anti-windup | overshoot [%] | settling 2 % [s] | time saturated [s] | I term, lowest … highest [N·m] | "
            "error at the end [rad]",
            rows,
        ),
        "",
        "*Time saturated*: control ticks after the step on which the torque limit cut the command (the "
        f"controller's `saturated` flag on `{spec.STATE.topic}`), times the 10 ms period. *I term*: "
        "the integral's share of the command after the step; beyond 2 N·m it is torque the motor can never "
        "give, stored up to be paid back as overshoot.",
        "",
        _verdict(results, responses),
        "",
        "Plot: `windup.png` (angle, integral term and command of every mode). Each run's bag and "
        "metrics are in the folder named after its mode.",
        "",
    ]
    return "\n".join(lines)


def _verdict(results: dict[str, Any], responses: list[Response]) -> str:
    none, best = results["none_overshoot_pct"], results["conditional_integration_overshoot_pct"]
    words = [
        f"What it shows: while the command is stuck at the limit, the error stays large and an integral "
        f"without anti-windup keeps growing (to {results['none_integral_max_nm']:.2f} N·m here, against a "
        f"{TORQUE_MAX_NM:g} N·m motor). When the arm reaches the target that stored-up integral is still "
        f"there and pushes it past: {none:.1f} % overshoot without anti-windup, against {best:.1f} % with "
        "conditional integration, which simply stops integrating while saturated."
    ]
    clamp = results.get("clamp_overshoot_pct")
    if clamp is not None:
        words.append(f"A clamp sized to the actuator (|Ki ∫e| ≤ {TORQUE_MAX_NM:g} N·m) gives {clamp:.1f} %.")
    tutorial = results.get("clamp_tutorial_overshoot_pct")
    if tutorial is not None:
        same = abs(tutorial - none) < 0.05
        words.append(
            f"The tutorial's own clamp (±10 rad·s on ∫e, so up to 100 N·m of I term) gives {tutorial:.1f} %"
            + (
                ", exactly what no anti-windup gives: its limit is never reached, so commenting out the "
                "tutorial's np.clip changes nothing at this torque limit. A clamp only helps if its limit "
                "is sized to the actuator."
                if same
                else f" (no anti-windup: {none:.1f} %): a clamp only helps if its limit is sized to the actuator."
            )
        )
    back = results.get("back_calculation_steady_state_error_rad")
    if back is not None:
        low = results["back_calculation_integral_min_nm"]
        words.append(
            f"Back-calculation has the opposite problem here: it feeds everything the limit cuts off back "
            f"into the integral, and right after the jump the proportional term alone asks for "
            f"Kp × {STEP_RAD:g} rad = {results['kp'] * STEP_RAD:g} N·m, so within its 0.1 s time constant "
            f"it drives the I term down to {low:.1f} N·m to cancel that. As the arm moves and the "
            f"proportional term shrinks, this negative integral holds the arm back, and with Ki = "
            f"{results['ki']:g} it takes seconds to unwind: {back * 1e3:.0f} mrad short of the target at "
            "the end. Back-calculation suits a loop in which the integral is what drives the output "
            "into the limit; against a proportional term this far beyond it, it needs a much longer time "
            "constant (`back_calculation_time_s`) or a reference the arm can follow (`step_shaping: "
            "min_time`)."
        )
    return " ".join(words)
