"""Exercise 1's plots, ``tune.png`` (every stage's step responses side by side) and ``tune_sine.png`` (the gains
chosen on the sine, the tutorial's beside them), and ``report.md``: each stage's runs as a table with what they show,
the gains chosen beside the tutorial's, and a verdict in words."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from robot_controller.experiments.exercises.ziegler_nichols.settings import (
    KP_START,
    KU_STEP_RAD,
    OVERSHOOT_MAX_PCT,
    SSE_MAX_FRACTION,
    STAGE_LEAD_S,
    STAGE_STEP_RAD,
    SUSTAINED_GROWTH_PER_S,
)
from robot_controller.experiments.reporting import cells, fmt, label_axes, pyplot, save, table
from robot_controller.experiments.step import Response, plot_steps


def plot_stages(
    path: Path, search, zn_response, kd_runs, ki_runs, chosen, tutorial_step, ku: float, kp: float, kd: float
) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(13, 8.5), constrained_layout=True)
    ordered = sorted(search, key=lambda r: r.figures["kp"])
    for response in ordered:
        tag = "oscillates on" if response.figures["sustained"] else "decays"
        response.label = f"Kp {response.figures['kp']:.3g} ({tag})"
    plot_steps(axes[0, 0], ordered, title=f"1. Kp alone (Ki = Kd = 0): Ku ≈ {ku:.3g} N·m/rad")
    plot_steps(
        axes[0, 1],
        ([zn_response] if zn_response else []) + kd_runs,
        title="2–3. Ziegler–Nichols, then Kd (Ki = 0) until the overshoot is gone",
    )
    plot_steps(
        axes[1, 0],
        ki_runs,
        title=f"4. then Ki (Kd {kd:.3g}) until the steady-state error is gone",
        band=(STAGE_STEP_RAD * 0.98, STAGE_STEP_RAD * 1.02),
    )
    final = [chosen] + ([tutorial_step] if tutorial_step else [])
    chosen.label = f"chosen: Kp {kp:.3g}, Ki {chosen.figures['ki']:.3g}, Kd {kd:.3g}"
    plot_steps(
        axes[1, 1],
        final + ([zn_response] if zn_response else []),
        title="the gains chosen",
        band=(STAGE_STEP_RAD * 0.98, STAGE_STEP_RAD * 1.02),
    )
    save(fig, path, "Exercise 1: tune the PID (the tutorial's controller, real graph, sim time)")


def plot_sine(path: Path, sine: Response, tutorial: Response | None) -> None:
    plt = pyplot()
    fig, (ax_q, ax_e) = plt.subplots(2, 1, figsize=(10, 6), sharex=True, constrained_layout=True)
    ax_q.plot(sine.time_s, sine.reference, "k--", lw=0.9, label="reference")
    for response in [sine] + ([tutorial] if tutorial else []):
        ax_q.plot(response.time_s, response.position, lw=1.1, label=response.label)
        ax_e.plot(response.time_s, response.reference - response.position, lw=1.0, label=response.label)
    label_axes(ax_q, ylabel="joint angle, true [rad]")
    label_axes(ax_e, "time [s]", "reference − true [rad]")
    save(fig, path, "The gains chosen on the sine (1 rad, 0.5 Hz)")


def report_text(
    results: dict[str, Any],
    plan: dict[str, Any],
    search: list[Response],
    rows: list[dict[str, Any]],
    quick: bool,
) -> str:
    ku, tu = results["ultimate_gain"], results["ultimate_period_s"]
    search_cols = (("kp", "{:.4g}"), ("amplitude_early_rad", "{:.3f}"), ("amplitude_late_rad", "{:.3f}"))
    search_cols += (("growth_per_s", "{:+.3f}"), ("period_s", "{:.3f}"))
    search_rows = [
        [str(index + 1), *cells(r.figures, search_cols), "oscillates on" if r.figures["sustained"] else "decays"]
        for index, r in enumerate(search)
    ]
    never = f"not in {plan['stage_after_s']:g} s"
    gains = (("kp", "{:.3g}"), ("ki", "{:.3g}"), ("kd", "{:.3g}"))
    stage_cols = (*gains, ("overshoot_pct", "{:.1f}"))
    stage_cols += (("overshoot_final_pct", "{:.1f}"), ("settling_time_s", "{:.2f}", never))
    stage_cols += (("steady_state_error_rad", "{:.4f}"), ("peak_torque_nm", "{:.2f}"))
    stage_rows = [[row["label"], *cells(row, stage_cols)] for row in rows]
    chosen_cols = (("step_overshoot_pct", "{:.1f}"), ("step_settling_time_s", "{:.2f}", never))
    chosen_cols += (("step_steady_state_error_rad", "{:.4f}"), ("sine_tracking_rms_rad", "{:.4f}"))
    text = [
        "# Exercise 1: tune the PID",
        "",
        "*The tutorial: start with Kp = 50, Ki = 0, Kd = 0. Increase Kp until oscillation, then add Kd, "
        "then Ki. Compare responses.*",
        "",
        "Every run below is the whole graph (simulator, motor, sensor, controller, planner as five "
        "processes) on sim time, so the same seed gives the same figures. The controller is the "
        f"tutorial's (`--preset tutorial`: PID, no feedforward, no Kalman filter, derivative on the measured "
        f"velocity) with only Kp, Ki and Kd changed. Figures are on the TRUE joint angle (sensor seed "
        f"{results['seed']})." + (" **Quick form**: fewer and shorter runs." if quick else ""),
        "",
        "## 1. Kp alone: the ultimate gain",
        "",
        f"A {KU_STEP_RAD} rad step with Ki = Kd = 0. The oscillation's amplitude in the first second after the "
        f"step is compared with the last second's: if it shrinks by less than {-SUSTAINED_GROWTH_PER_S:.0%} "
        "a second, the loop oscillates on by itself.",
        "",
        table(
            "run | Kp [N·m/rad] | amplitude, first s [rad] | amplitude, last s [rad] | growth [1/s] | period [s] | "
            "verdict",
            search_rows,
        ),
        "",
        f"**Ultimate gain Ku = {ku:.3g} N·m/rad**, the smallest Kp that oscillated on (at "
        f"{results['ultimate_gain_bracket_low']:.3g} it still decayed), **period Tu = {fmt(tu, '{:.3f}')} s**. "
        "The arm's linear model, sampled at the control rate, puts the "
        f"limit at Ku = {results['model_ultimate_gain']:.3g} N·m/rad, Tu = "
        f"{results['model_ultimate_period_s']:.3f} s.",
        "",
        "What it shows: the arm itself would never oscillate under P control alone (its friction damps "
        "any gain in continuous time). The oscillation comes from the loop being *sampled*: the torque is "
        "held for a whole 10 ms period, which acts like a 5 ms delay, and the arm has so little friction "
        "that this delay is enough to undamp it. The tutorial's starting point Kp = 50 is already "
        "beyond that limit on this arm"
        + (" (run 1 above)." if search[0].figures["kp"] == KP_START and search[0].figures["sustained"] else "."),
        "",
        "## 2–4. Then Kd, then Ki",
        "",
        f"Ziegler–Nichols' classic rule turns Ku and Tu into a starting point: Kp = 0.6 Ku = "
        f"{results['zn_kp']:.3g}, Ki = 1.2 Ku/Tu = {results['zn_ki']:.3g}, Kd = 0.075 Ku Tu = "
        f"{results['zn_kd']:.3g}. Keeping its Kp, Kd is raised (Ki = 0) until the overshoot is gone "
        f"(≤ {OVERSHOOT_MAX_PCT:g} % beyond where the response ends: without Ki the arm sags under gravity and "
        f"never reaches the target), then Ki (as Kp/Ti) until the steady-state error is gone "
        f"(≤ {SSE_MAX_FRACTION:.0%} of the {STAGE_STEP_RAD} rad step), stopping before the overshoot comes "
        f"back. Step {STAGE_STEP_RAD} rad, a jump, after {STAGE_LEAD_S:g} s at rest.",
        "",
        table(
            "run | Kp | Ki | Kd | overshoot of target [%] | overshoot of final value [%] | settling 2 % [s] | "
            "steady-state error [rad] | peak torque [N·m]",
            stage_rows,
        ),
        "",
        "## The gains chosen",
        "",
        table(
            " | Kp [N·m/rad] | Ki [N·m/(rad·s)] | Kd [N·m·s/rad] | step overshoot [%] | settling 2 % [s] | "
            "steady-state error [rad] | sine RMS error [rad]",
            [["chosen", *cells(results, gains), *cells(results, chosen_cols)]]
            + (
                [["the tutorial's", "50", "10", "5", *cells(results, chosen_cols, "tutorial_")]]
                if "tutorial_sine_tracking_rms_rad" in results
                else []
            ),
        ),
        "",
        f"Sine: 1 rad, 0.5 Hz, {plan['sine_s']:g} s, RMS of (reference − true angle) after a 2 s warm-up. "
        f"Margins of the chosen gains on the sampled arm model: gain "
        f"{fmt(results['margin_gain_margin_db'], '{:.1f}')} dB, phase "
        f"{fmt(results['margin_phase_margin_deg'], '{:.0f}')}°, delay {results['margin_delay_periods']} "
        "whole control period(s).",
        "",
        _verdict(results, plan),
        "",
        "Plots: `tune.png` (every stage's steps side by side), `tune_sine.png` (the chosen gains on the "
        "sine). Each run's bag and metrics are in the folders beside this report.",
        "",
    ]
    return "\n".join(text)


def _verdict(results: dict[str, Any], plan: dict[str, Any]) -> str:
    """What the chosen gains show, in words, from their figures."""
    overshoot, sse = results["step_overshoot_pct"], results["step_steady_state_error_rad"]
    settling = results["step_settling_time_s"]
    clean = overshoot <= OVERSHOOT_MAX_PCT and sse <= SSE_MAX_FRACTION * STAGE_STEP_RAD
    words = [
        "What it shows: the recipe ends "
        + (
            f"clean on the step (overshoot {overshoot:.1f} %, steady-state error {sse * 1e3:.1f} mrad)"
            if clean
            else f"with overshoot {overshoot:.1f} % and a steady-state error of {sse * 1e3:.1f} mrad"
        )
        + (
            f", settled {settling:.2f} s after it"
            if np.isfinite(settling or np.nan)
            else f", not settled within {plan['stage_after_s']:g} s"
        )
        + "."
    ]
    words.append(
        f"Every gain is scaled from Ku = {results['ultimate_gain']:.3g} N·m/rad, which is small on an arm "
        "this lightly damped, so the loop is gentle: once Kd damps it, a much larger Kp is stable (the "
        "ultimate gain of P alone is not the limit of a PD), as the tutorial's own Kp = 50 with Kd = 5 is."
    )
    if "tutorial_sine_tracking_rms_rad" in results:
        ours, theirs = results["sine_tracking_rms_rad"], results["tutorial_sine_tracking_rms_rad"]
        words.append(
            f"On the sine the chosen gains track with {ours * 1e3:.0f} mrad RMS, the tutorial's with "
            f"{theirs * 1e3:.0f} mrad: "
            + (
                "the stiffer loop follows a moving reference better."
                if theirs < ours
                else "the recipe's gains track better."
            )
        )
    words.append(
        "Without feedforward every gain choice lags a moving reference: `robot-controller tune` searches "
        "the gains (or the LQR weights) against the sine directly, keeping gain, phase and delay margins."
    )
    return " ".join(words)
