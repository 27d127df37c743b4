"""What ``tune`` of a built-in law writes for people: ``tuned.yaml``'s header, ``tune.png`` (every gain
set that met the margins, coloured by its tracking error) and ``report.md``."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller.experiments.autotune.analytic import AnalyticProblem
from robot_controller.experiments.autotune.margins import (
    MAX_TIME_CONSTANT_S,
    MIN_DELAY_PERIODS,
    MIN_GAIN_MARGIN_DB,
    MIN_PHASE_MARGIN_DEG,
)
from robot_controller.experiments.autotune.search import ROBUST, SearchResult
from robot_controller.experiments.reporting import fmt, label_axes, pyplot, save, table


def yaml_header(problem: AnalyticProblem, result: SearchResult) -> str:
    what = "Kp, Ki, Kd" if problem.controller_type == "pid" else "lqr_q (lqr_r unchanged)"
    return (
        f"# robot-controller tune: {what} for controller_type {problem.controller_type}, feedforward "
        f"{problem.feedforward}, chosen on the batch harness (sine RMS {result.best_rms:.3g} rad) with gain "
        f"margin >= {MIN_GAIN_MARGIN_DB:g} dB, phase margin >= {MIN_PHASE_MARGIN_DEG:g} deg, delay margin >= "
        f"{MIN_DELAY_PERIODS} control periods, no lower gain limit, slowest pole within "
        f"{MAX_TIME_CONSTANT_S:g} s.\n"
    )


def plot(path: Path, result: SearchResult) -> None:
    plt = pyplot()
    problem = result.problem
    before = problem.before_gains()
    best_gains = problem.gains_of_values(result.best_values)[0]
    robust = result.history.verdict == ROBUST
    gains, rms = result.history.detail[robust], result.history.rms[robust]
    finite = np.isfinite(rms)
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.5), constrained_layout=True)
    pairs = (
        (0, 2, "Kp [N·m/rad]", "Kd [N·m·s/rad]"),
        (0, 1, "Kp [N·m/rad]", "Ki [N·m/(rad·s)]"),
        (2, 1, "Kd [N·m·s/rad]", "Ki [N·m/(rad·s)]"),
    )
    for ax, (x, y, xlabel, ylabel) in zip(axes, pairs, strict=True):
        points = ax.scatter(gains[finite, x], gains[finite, y], c=np.log10(rms[finite]), s=6, cmap="viridis_r")
        ax.plot(before[x], before[y], "rs", ms=9, mfc="none", mew=2, label="before")
        ax.plot(best_gains[x], best_gains[y], "r*", ms=14, label="after")
        ax.set_xscale("log")
        ax.set_yscale("log")
        label_axes(ax, xlabel, ylabel)
    fig.colorbar(points, ax=axes[-1], label="log10 sine RMS [rad] (batch)")
    save(fig, path, f"Gain sets that met every margin ({int(np.count_nonzero(finite))}), coloured by tracking error")


def report_text(values: dict[str, Any], problem: AnalyticProblem, result: SearchResult, quick: bool) -> str:
    def f(value: Any, spec: str = "{:.3g}") -> str:
        return "∞" if value == math.inf else fmt(value, spec)

    lqr_mode = problem.controller_type == "lqr"
    searched = "the LQR weights lqr_q (lqr_r kept: only their ratio matters)" if lqr_mode else "Kp, Ki, Kd"
    columns = (("kp", "{:.3g}"), ("ki", "{:.3g}"), ("kd", "{:.3g}"), ("gain_margin_db", "{:.1f}"))
    columns += (("gain_margin_low_db", "{:.1f}"), ("phase_margin_deg", "{:.0f}"))
    rows = []
    for name in ("before", "after"):
        weights = []
        if lqr_mode:
            q = ", ".join(f(values[f"{name}_lqr_q_{key}"]) for key in ("integral", "position", "velocity"))
            weights = [f"[{q}], {f(values[f'{name}_lqr_r'])}"]
        rows.append(
            [
                f"**{name}**",
                *weights,
                *(f(values[f"{name}_{key}"], spec) for key, spec in columns),
                str(values[f"{name}_delay_margin_periods"]),
                "yes" if values[f"{name}_meets_constraints"] else "**no**",
                f(values[f"{name}_slowest_time_constant_s"], "{:.2g}"),
                f(values[f"batch_rms_{name}_rad"] * 1e3, "{:.3f}"),
                f(values[f"real_rms_{name}_rad"] * 1e3, "{:.3f}"),
            ]
        )
    headers = (" | lqr_q, lqr_r" if lqr_mode else "") + (
        " | Kp | Ki | Kd | gain margin, up [dB] | gain margin, down [dB] | phase margin [°] | delay margin [periods] | "
        "meets the margins | slowest pole, τ [s] | sine RMS, batch [mrad] | sine RMS, real graph [mrad]"
    )
    real_before, real_after = values["real_rms_before_rad"], values["real_rms_after_rad"]
    ratio = max(real_before, real_after) / max(min(real_before, real_after), 1e-12)
    change = (
        f"the real graph's sine RMS goes from {real_before * 1e3:.3f} to {real_after * 1e3:.3f} mrad ("
        + (f"{abs(real_after / real_before - 1) * 100:.0f} % " if ratio < 1.5 else f"a factor {ratio:.2g} ")
        + ("better)" if real_after < real_before else "worse)")
    )
    lines = [
        "# Automatic gain design",
        "",
        f"Controller type **{problem.controller_type}**, feedforward {problem.feedforward}, derivative on "
        f"{problem.law.derivative_source.value}, anti-windup {problem.law.anti_windup.value}, torque limit "
        f"{problem.torque_max:g} N·m." + (" **Quick form**: a smaller search and shorter runs." if quick else ""),
        "",
        f"Searched: {searched} on the batch harness: {result.evaluated} gain sets in {len(result.rounds)} "
        "rounds (a Latin hypercube over a wide log-scaled box, then samples around the best, narrower each "
        "round), of which "
        f"{result.robust} met every margin and were simulated ({values['batch_duration_s']:g} s of the sine "
        f"each, the first 2 s not scored); {values['search_wall_s']:.1f} s in all.",
        "",
        f"Margins required of the sampled loop (the arm linearised at rest, zero-order hold every "
        f"{problem.dt * 1e3:g} ms, the feedback on [∫e, e, ė]): gain ≥ {MIN_GAIN_MARGIN_DB:g} dB, phase ≥ "
        f"{MIN_PHASE_MARGIN_DEG:g}°, stable with {MIN_DELAY_PERIODS} control periods of extra delay, and "
        "stable however much the loop gain drops (∞ dB down: saturation lowers the gain, and a loop that is "
        "unstable at a lower gain can swing into a limit cycle when the torque saturates); and the slowest "
        f"closed-loop pole's time constant at most {MAX_TIME_CONSTANT_S:g} s (integral action that removes a "
        "steady load within seconds, which the sine alone does not reward).",
        "",
        table(headers, rows),
        "",
        f"Real graph: one seeded sine run on sim time each, {values['real_duration_s']:g} sim s (2 s warm-up), RMS "
        f"of (reference − true angle): {change}.",
        "",
        *_caveats(values),
        "The batch figure and the real one differ where the batch is simpler than the graph: it simulates the "
        "arm analytically and evaluates the reference at every tick (the planner's rate and the controller's "
        "hold of a sample are not modelled); every gain set meets the same sensor noise there, a different "
        "draw from the real run's.",
        "",
        f"Use it: `robot-controller run --config {Path('tuned.yaml')}` over the same preset and files (the "
        "file's first lines say what it was tuned for). Plot: `tune.png` (every gain set that met the margins, "
        "coloured by its tracking error; before and after marked).",
        "",
    ]
    return "\n".join(lines)


def _caveats(values: dict[str, Any]) -> list[str]:
    """What the sine objective does not weigh, where it shows in the result."""
    tau = values["after_slowest_time_constant_s"]
    if tau is None or not math.isfinite(tau) or tau <= 1.0:
        return []
    return [
        f"The objective is the sine alone. The tuned loop's slowest pole has a time constant of {tau:.3g} s "
        "(its integral is weak): a steady load that the feedforward does not cancel (a payload, a push, gravity "
        "without feedforward) is removed that slowly. Weigh that before using it where loads change.",
        "",
    ]
