"""What ``tune`` of a law of one's own writes for people: ``tuned.yaml``'s header, ``tune.png`` (every
candidate's tracking error, by parameter) and ``report.md``."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller.experiments.autotune.blackbox import (
    CASES,
    DECAY_FLOOR_RAD,
    DECAY_FRACTION,
    DELAY_REPORTED_UP_TO,
    PUSH_AT_S,
    PUSH_FRACTION,
    PUSH_PERIODS,
    SETTLE_S,
    TAIL_S,
    BlackBoxProblem,
    RobustnessCase,
)
from robot_controller.experiments.autotune.margins import MAX_TIME_CONSTANT_S, MIN_DELAY_PERIODS, MIN_GAIN_MARGIN_DB
from robot_controller.experiments.autotune.search import FAILED, ROBUST, UNCHECKED, SearchResult
from robot_controller.experiments.reporting import fmt, label_axes, pyplot, save, table


def yaml_header(problem: BlackBoxProblem, result: SearchResult) -> str:
    return (
        f"# robot-controller tune --controller: {', '.join(k.name for k in problem.knobs)} of {problem.spec}, "
        f"chosen on the in-process loop (sine RMS {result.best_rms:.3g} rad) where a push still dies away "
        f"within {SETTLE_S:g} s with the readings {MIN_DELAY_PERIODS} periods late, with the drive's gain "
        f"±{MIN_GAIN_MARGIN_DB:g} dB, and as configured.\n"
    )


def plot(path: Path, result: SearchResult) -> None:
    plt = pyplot()
    before = result.problem.current()
    knob_list = result.problem.knobs
    fig, axes = plt.subplots(1, len(knob_list), figsize=(4.5 * len(knob_list), 4), constrained_layout=True)
    axes = np.atleast_1d(axes)
    values, rms, verdict = result.history.values, result.history.rms, result.history.verdict
    finite = np.isfinite(rms)
    for j, (ax, knob) in enumerate(zip(axes, knob_list, strict=True)):
        for label, mask, style in (
            ("not checked", verdict == UNCHECKED, dict(c="0.6", s=8)),
            ("failed a case", verdict == FAILED, dict(c="tab:red", marker="x", s=30)),
            ("passed every case", verdict == ROBUST, dict(c="tab:green", s=30)),
        ):
            mask = mask & finite
            if np.any(mask):
                ax.scatter(values[mask, j], rms[mask] * 1e3, label=label, **style)
        ax.axvline(before[j], color="k", ls="--", lw=0.8, label="before")
        ax.axvline(result.best_values[j], color="tab:green", lw=1.2, label="after")
        ax.set_xscale("log" if knob.log else "linear")
        ax.set_yscale("log")
        label_axes(ax, knob.name, "sine RMS, in process [mrad]", legend=None)
    axes[0].legend(fontsize=8)
    save(fig, path, f"tune --controller {result.problem.spec}: every candidate run")


def report_text(values: dict[str, Any], problem: BlackBoxProblem, result: SearchResult, quick: bool) -> str:
    f = fmt

    def cell(name: str, case: RobustnessCase) -> str:
        ok = values[f"{name}_{case.name}_ok"]
        if values[f"{name}_{case.name}_saturated"]:
            return "**no** (saturated)"
        left = values[f"{name}_{case.name}_left_fraction"]
        return ("yes" if ok else "**no**") + f" ({f(left * 100 if left == left else None, '{:.1f}')} %)"

    headers = [
        "",
        *[k.name for k in problem.knobs],
        *[c.name.replace("_", " ") + ": dies away (left)" for c in CASES],
        "delay margin [periods]",
        "meets every case",
        "sine RMS, search [mrad]",
        "sine RMS, check [mrad]",
    ]
    rows = [
        [
            f"**{name}**",
            *[f(values[f"{name}_{k.name}"], "{:.4g}") for k in problem.knobs],
            *[cell(name, c) for c in CASES],
            str(values[f"{name}_delay_margin_periods"])
            + ("+" if values[f"{name}_delay_margin_periods"] == DELAY_REPORTED_UP_TO else ""),
            "yes" if values[f"{name}_meets_constraints"] else "**no**",
            f(values[f"{name}_search_rms_rad"] * 1e3, "{:.3f}"),
            f(values[f"{name}_check_rms_rad"] * 1e3, "{:.3f}"),
        ]
        for name in ("before", "after")
    ]
    ranges = ", ".join(f"{k.name} {k.low:g}…{k.high:g}" + (" (log)" if k.log else "") for k in problem.knobs)
    before, after = values["before_check_rms_rad"], values["after_check_rms_rad"]
    change = (
        f"from {before * 1e3:.3f} to {after * 1e3:.3f} mrad"
        if math.isfinite(before) and math.isfinite(after)
        else f"{f(before * 1e3)} → {f(after * 1e3)} mrad"
    )
    lines = [
        "# Automatic gain design: a law of one's own",
        "",
        f"Controller type **{problem.spec}**. Searched: its parameters declared `gain=True`, within their "
        f"ranges: {ranges}; one value for every joint." + (" **Quick form**: a smaller search." if quick else ""),
        "",
        f"The law is a black box, so each candidate ran the in-process loop (the sim-time graph's computation, no "
        f"ROS; the batch harness runs the built-in PID only): {result.evaluated} candidates, "
        f"{values['search_duration_s']:g} s of the sine each with the sensor's noise (seed {values['seed']}, "
        f"the same for all; the first 2 s not scored), in {len(result.rounds)} rounds (a Latin hypercube, then "
        f"samples around the best robust, narrower each round); {values['search_wall_s']:.1f} s in all.",
        "",
        "Robustness, measured (the built-in tune's margins as a black box shows them), on the configured loop "
        "without the Kalman filter's disturbance observer (it reads an unknown delay or gain as a push and fights "
        "it; the built-in margins are the law's and the arm's alone): a push of "
        f"{PUSH_FRACTION * 100:g} % of each joint's torque limit for {PUSH_PERIODS} control periods at "
        f"{PUSH_AT_S:g} s, its own effect taken against the same run unpushed (the same noise draws), must die "
        f"down to {DECAY_FRACTION * 100:.0f} % of its peak (or {DECAY_FLOOR_RAD * 1e3:g} mrad) within "
        f"{SETTLE_S:g} s, about a slowest time constant of {MAX_TIME_CONSTANT_S:g} s, in each case: "
        + "; ".join(f"*{c.name.replace('_', ' ')}*: {c.description}" for c in CASES)
        + f". {result.checked} candidates, the best-tracking first, were checked; {result.robust} passed. Not "
        "checked: the phase margin (no crossover to measure on a black box; the delay case bounds the phase "
        "lost to delay) and gains beyond ±6 dB.",
        "",
        table(headers, rows),
        "",
        f"*Left*: the push's own effect over the last {TAIL_S:g} s, as a share of its peak; *saturated*: the "
        "torque reached its limit after the warm-up (an unstable loop's swing; both runs would then swing alike)."
        " *Delay margin*: the most whole control periods of unstamped delay after which the push still dies "
        "away (checked up to "
        f"{DELAY_REPORTED_UP_TO}). *Check*: {values['check_duration_s']:g} s of the sine on another noise seed "
        f"({values['check_seed']}): {change}.",
        "",
        f"Use it: `robot-controller run --config {Path('tuned.yaml')}` over the same preset and files (it sets "
        "controller_type too). Plot: `tune.png` (every candidate's tracking error, by parameter).",
        "",
    ]
    return "\n".join(lines)
