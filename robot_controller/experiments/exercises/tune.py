"""Exercise 1, "Tune the PID": start with Kp = 50, Ki = Kd = 0; increase Kp
until oscillation, then add Kd, then Ki; compare the responses.

Automated on the real graph (every run a seeded five-process lockstep run of
the tutorial's controller: PID, no feedforward, no Kalman filter):

1. **Kp alone** (Ki = Kd = 0) on a small step: from the tutorial's Kp = 50,
   halve or double until one run oscillates without end and another does not,
   then bisect. A run *oscillates without end* when its oscillation's amplitude
   does not decay from the first second after the step to the last one
   (:func:`oscillation`). The smallest such Kp is the ultimate gain Ku; the
   period of that oscillation is Tu.
2. **Ziegler–Nichols** (the classic PID rule) from Ku and Tu, as the textbook's
   starting point: Kp = 0.6 Ku, Ki = 1.2 Ku/Tu, Kd = 0.075 Ku Tu.
3. **Then Kd**: at the rule's Kp, Ki = 0, Kd from the rule's value, doubled
   until the step's overshoot is gone (≤ 2 % beyond where the response ends).
4. **Then Ki**: Ki = Kp/Ti with the integral time Ti from 8 Tu down to Tu,
   until the steady-state error is gone (≤ 1 % of the step), stopping before
   the overshoot comes back (> 2 %).
5. The gains chosen on the sine; in the full form the tutorial's own gains
   (50, 10, 5) beside them.

Longer than our ~250-line guideline: the tutorial's procedure in four stages,
each with its runs and its part of the report.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.core import lqr, robustness
from robot_controller.experiments.exercises.common import (
    SEED,
    Exercise,
    Progress,
    Response,
    fmt,
    plant_loop,
    plot_steps,
    pyplot,
    sine_params,
    sine_run,
    step_run,
    table,
    write_report,
    write_results,
)

PRESET = "tutorial"
KP_START = 50.0  #: the tutorial's starting point, N·m/rad
KU_STEP_RAD = 0.2  #: the Kp search's step: small, so the oscillation stays inside the torque limit at first
STAGE_STEP_RAD = 0.5  #: the Kd and Ki stages' step
STAGE_LEAD_S = 1.0  #: at rest before the step (the arm sags under gravity first: no feedforward)
SUSTAINED_GROWTH_PER_S = -0.02  #: an amplitude shrinking slower than 2 %/s is not decaying
NOISE_FLOOR_RAD = 0.005  #: an oscillation smaller than this (the sensor's σ) is no oscillation
OVERSHOOT_MAX_PCT = 2.0  #: "overshoot gone" (the tutorial's "< 2 %")
SSE_MAX_FRACTION = 0.01  #: "steady-state error gone": within 1 % of the step
TUTORIAL_GAINS = (50.0, 10.0, 5.0)


def _plan(quick: bool) -> dict[str, Any]:
    if quick:
        return {
            "ku_runs": 3,
            "ku_after_s": 2.5,
            "kd_factors": (4.0,),
            "ti_tu": (4.0,),
            "stage_after_s": 1.5,
            "sine_s": 3.0,
            "zn_run": False,
            "tutorial_runs": False,
        }
    return {
        "ku_runs": 8,
        "ku_after_s": 4.0,
        "kd_factors": (1.0, 2.0, 4.0, 8.0),
        "ti_tu": (8.0, 4.0, 2.0, 1.0),
        "stage_after_s": 2.0,
        "sine_s": 10.0,
        "zn_run": True,
        "tutorial_runs": True,
    }


def steps(quick: bool = False) -> int:
    plan = _plan(quick)
    return (
        plan["ku_runs"]
        + int(plan["zn_run"])
        + len(plan["kd_factors"])
        + len(plan["ti_tu"])
        + 1
        + 2 * int(plan["tutorial_runs"])
    )


def _gains(params: cfg.Params, kp: float, ki: float, kd: float) -> cfg.Params:
    return cfg.merge(params, {"pid_controller": {"kp": [float(kp)], "ki": [float(ki)], "kd": [float(kd)]}})


def oscillation(response: Response, *, settle_s: float = 0.3, window_s: float = 1.0) -> dict[str, float]:
    """How the oscillation after a step evolves, from the TRUE angle.

    The amplitude (half the peak-to-peak about the window's mean) in the
    first ``window_s`` after ``settle_s`` past the step, and in the last
    ``window_s`` of the record; ``growth_per_s`` = ln(late / early) / their
    distance (negative: decaying); ``sustained`` when it does not decay and
    is larger than the sensor noise at the end; ``period_s``: the mean spacing of upward
    crossings of the mean after ``settle_s`` (NaN if fewer than two).
    """
    t, q = response.time_s, response.position
    after = (t >= settle_s) & np.isfinite(q)
    t, q = t[after], q[after]
    end = t[-1]
    early = t < settle_s + window_s
    late = t > end - window_s

    def amplitude(mask: np.ndarray) -> float:
        x = q[mask] - np.mean(q[mask])
        return 0.5 * float(np.max(x) - np.min(x))

    a_early, a_late = amplitude(early), amplitude(late)
    span = (end - window_s / 2) - (settle_s + window_s / 2)
    growth = float(np.log(max(a_late, 1e-12) / max(a_early, 1e-12)) / span)
    x = q - np.mean(q)
    up = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    crossings = t[up] + (t[up + 1] - t[up]) * (-x[up] / (x[up + 1] - x[up]))
    period = float(np.mean(np.diff(crossings))) if len(crossings) >= 2 else float("nan")
    sustained = growth >= SUSTAINED_GROWTH_PER_S and a_late >= NOISE_FLOOR_RAD
    return {
        "amplitude_early_rad": a_early,
        "amplitude_late_rad": a_late,
        "growth_per_s": growth,
        "period_s": period,
        "sustained": int(sustained),
    }


def model_ultimate(params: cfg.Params) -> tuple[float, float]:
    """Ku and Tu of the sampled arm model (``lqr.discretise``: the arm linearised
    at rest, zero-order hold at the control period) under P alone: the Kp at
    which the closed loop's poles reach the unit circle, and the period of the
    oscillation there."""
    A, B, dt = plant_loop(params)
    A, B = A[1:, 1:], B[1:]  # P alone: ∫e plays no part

    def radius(kp: float) -> float:
        return float(robustness.spectral_radius(A, B, np.array([[kp, 0.0]]))[0])

    low, high = 0.0, 1.0
    while radius(high) < 1.0:
        low, high = high, high * 2
        if high > 1e7:
            return float("inf"), float("nan")
    for _ in range(60):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if radius(mid) < 1.0 else (low, mid)
    pole = robustness.poles(A, B, np.array([[high, 0.0]]))[0]
    return high, float(2 * np.pi * dt / abs(np.angle(pole)))


def run(out: Path, *, quick: bool = False, progress: Progress = print, seed: int = SEED) -> dict[str, Any]:
    out.mkdir(parents=True, exist_ok=True)
    plan = _plan(quick)
    base = cfg.load_stack(PRESET)
    results: dict[str, Any] = {"quick": int(quick), "seed": seed}
    rows: list[dict[str, Any]] = []  # every run, for the tables

    # 1. Kp alone, until it oscillates without end.
    low: float | None = None  # the largest Kp that decayed
    high: float | None = None  # the smallest Kp that did not
    search: list[Response] = []
    for index in range(plan["ku_runs"]):
        if low is None and high is None:
            kp = KP_START
        elif high is None:
            kp = 2.0 * low
        elif low is None:
            kp = 0.5 * high
        else:
            kp = 0.5 * (low + high)
        progress(f"Kp alone: Kp = {kp:.4g} (run {index + 1} of {plan['ku_runs']})")
        response = step_run(
            _gains(base, kp, 0.0, 0.0),
            out / "kp_search" / f"run_{index + 1}",
            f"Kp {kp:.3g}",
            amplitude=KU_STEP_RAD,
            after_s=plan["ku_after_s"],
            seed=seed,
        )
        response.figures.update(oscillation(response))
        response.figures["kp"] = kp
        search.append(response)
        if response.figures["sustained"]:
            high = kp if high is None else min(high, kp)
        else:
            low = kp if low is None else max(low, kp)
        for key in ("kp", "growth_per_s", "amplitude_early_rad", "amplitude_late_rad", "period_s", "sustained"):
            results[f"kp_search_{index + 1}_{key}"] = response.figures[key]
    if high is None or low is None:
        raise RuntimeError(
            f"tune: no bracket of the ultimate gain in {plan['ku_runs']} runs from Kp {KP_START:g} "
            f"(sustained from {high}, decaying up to {low}); see {out / 'kp_search'}"
        )
    at_ku = next(r for r in search if r.figures["kp"] == high)
    ku, tu = high, at_ku.figures["period_s"]
    model_ku, model_tu = model_ultimate(base)
    results.update(
        {
            "ultimate_gain": ku,
            "ultimate_period_s": tu,
            "ultimate_gain_bracket_low": low,
            "model_ultimate_gain": model_ku,
            "model_ultimate_period_s": model_tu,
        }
    )

    # 2. Ziegler–Nichols' classic PID from Ku, Tu.
    zn = (0.6 * ku, 1.2 * ku / tu, 0.075 * ku * tu)
    results.update({"zn_kp": zn[0], "zn_ki": zn[1], "zn_kd": zn[2]})
    stage_kwargs = {"amplitude": STAGE_STEP_RAD, "lead_s": STAGE_LEAD_S, "after_s": plan["stage_after_s"], "seed": seed}
    zn_response = None
    if plan["zn_run"]:
        progress(f"Ziegler–Nichols PID: Kp {zn[0]:.3g}, Ki {zn[1]:.3g}, Kd {zn[2]:.3g}")
        zn_response = step_run(_gains(base, *zn), out / "ziegler_nichols", "Ziegler–Nichols", **stage_kwargs)
        _store(results, "zn_step", zn_response.figures)
        rows.append(_row("Ziegler–Nichols PID", zn, zn_response))

    # 3. Then Kd, until the overshoot is gone.
    kp = zn[0]
    kd_runs: list[Response] = []
    kd = None
    for index, factor in enumerate(plan["kd_factors"]):
        candidate = zn[2] * factor
        progress(f"then Kd: Kp {kp:.3g}, Kd {candidate:.3g}, Ki 0")
        response = step_run(
            _gains(base, kp, 0.0, candidate),
            out / "kd_stage" / f"run_{index + 1}",
            f"Kd {candidate:.3g}",
            **stage_kwargs,
        )
        response.figures["kd"] = candidate
        kd_runs.append(response)
        rows.append(_row(f"Kd stage {index + 1}", (kp, 0.0, candidate), response))
        results[f"kd_stage_{index + 1}_kd"] = candidate
        results[f"kd_stage_{index + 1}_overshoot_final_pct"] = response.figures["overshoot_final_pct"]
        if kd is None and response.figures["overshoot_final_pct"] <= OVERSHOOT_MAX_PCT:
            kd = candidate
    if kd is None:  # none was clean enough: the least overshoot
        kd = min(kd_runs, key=lambda r: r.figures["overshoot_final_pct"]).figures["kd"]

    # 4. Then Ki, until the steady-state error is gone (and before the overshoot returns).
    ki_runs: list[Response] = []
    for index, ti_tu in enumerate(plan["ti_tu"]):
        candidate = kp / (ti_tu * tu)
        progress(f"then Ki: Kp {kp:.3g}, Kd {kd:.3g}, Ki {candidate:.3g} (Ti = {ti_tu:g} Tu)")
        response = step_run(
            _gains(base, kp, candidate, kd),
            out / "ki_stage" / f"run_{index + 1}",
            f"Ki {candidate:.3g}",
            **stage_kwargs,
        )
        response.figures["ki"] = candidate
        ki_runs.append(response)
        rows.append(_row(f"Ki stage {index + 1}", (kp, candidate, kd), response))
        results[f"ki_stage_{index + 1}_ki"] = candidate
        results[f"ki_stage_{index + 1}_steady_state_error_rad"] = response.figures["steady_state_error_rad"]
        results[f"ki_stage_{index + 1}_overshoot_pct"] = response.figures["overshoot_pct"]
    chosen = choose_ki(ki_runs, STAGE_STEP_RAD)
    ki = chosen.figures["ki"]
    results.update({"kp": kp, "ki": ki, "kd": kd})
    _store(results, "step", chosen.figures)

    # 5. The gains chosen on the sine (and the tutorial's own gains beside them).
    progress(f"the gains chosen on the sine: Kp {kp:.3g}, Ki {ki:.3g}, Kd {kd:.3g}")
    sine = sine_run(
        _gains(sine_params(base), kp, ki, kd), out / "sine_chosen", "chosen", duration_s=plan["sine_s"], seed=seed
    )
    results["sine_tracking_rms_rad"] = sine.figures["tracking_rms_rad"]
    results["sine_tracking_max_rad"] = sine.figures["tracking_max_rad"]
    tutorial_step = tutorial_sine = None
    if plan["tutorial_runs"]:
        progress("the tutorial's gains (50, 10, 5): step")
        tutorial_step = step_run(
            _gains(base, *TUTORIAL_GAINS), out / "tutorial_step", "tutorial (50, 10, 5)", **stage_kwargs
        )
        _store(results, "tutorial_step", tutorial_step.figures)
        progress("the tutorial's gains (50, 10, 5): sine")
        tutorial_sine = sine_run(
            _gains(sine_params(base), *TUTORIAL_GAINS),
            out / "sine_tutorial",
            "tutorial",
            duration_s=plan["sine_s"],
            seed=seed,
        )
        results["tutorial_sine_tracking_rms_rad"] = tutorial_sine.figures["tracking_rms_rad"]

    margins = _margins(base, kp, ki, kd)
    results.update(margins.as_dict("margin_"))
    results["margin_delay_periods"] = _delay_periods(base, kp, ki, kd)
    results = write_results(out, results)
    _plot(out / "tune.png", search, zn_response, kd_runs, ki_runs, chosen, tutorial_step, ku, kp, kd)
    _plot_sine(out / "tune_sine.png", sine, tutorial_sine)
    write_report(out, _report(results, plan, search, rows, chosen, quick))
    return results


def choose_ki(runs: list[Response], step_rad: float) -> Response:
    """Up the Ki candidates (increasing): the first whose steady-state error is
    gone, unless the overshoot came back before it (then the one before)."""
    chosen = None
    for response in runs:
        if chosen is not None and response.figures["overshoot_pct"] > OVERSHOOT_MAX_PCT:
            break
        chosen = response
        if response.figures["steady_state_error_rad"] <= SSE_MAX_FRACTION * step_rad:
            break
    assert chosen is not None, "no Ki candidate"
    return chosen


def _store(results: dict[str, Any], prefix: str, figures: dict[str, Any]) -> None:
    for key in (
        "overshoot_pct",
        "overshoot_final_pct",
        "settling_time_s",
        "rise_time_s",
        "steady_state_error_rad",
        "peak_torque_nm",
        "saturated_s",
    ):
        results[f"{prefix}_{key}"] = figures[key]


def _row(label: str, gains: tuple[float, float, float], response: Response) -> dict[str, Any]:
    return {"label": label, "kp": gains[0], "ki": gains[1], "kd": gains[2], **response.figures}


def _margins(params: cfg.Params, kp: float, ki: float, kd: float) -> robustness.Margins:
    A, B, dt = plant_loop(params)
    return robustness.margins(A, B, robustness.pid_gain_row(kp, ki, kd), dt)


def _delay_periods(params: cfg.Params, kp: float, ki: float, kd: float) -> int:
    A, B, _ = plant_loop(params)
    return lqr.delay_margin_periods(A, B, robustness.pid_gain_row(kp, ki, kd))


def _plot(
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
    fig.suptitle("Exercise 1: tune the PID (the tutorial's controller, real graph, lockstep)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _plot_sine(path: Path, sine: Response, tutorial: Response | None) -> None:
    plt = pyplot()
    fig, (ax_q, ax_e) = plt.subplots(2, 1, figsize=(10, 6), sharex=True, constrained_layout=True)
    ax_q.plot(sine.time_s, sine.reference, "k--", lw=0.9, label="reference")
    for response in [sine] + ([tutorial] if tutorial else []):
        ax_q.plot(response.time_s, response.position, lw=1.1, label=response.label)
        ax_e.plot(response.time_s, response.reference - response.position, lw=1.0, label=response.label)
    ax_q.set_ylabel("joint angle, true [rad]")
    ax_e.set_ylabel("reference − true [rad]")
    ax_e.set_xlabel("time [s]")
    for ax in (ax_q, ax_e):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("The gains chosen on the sine (1 rad, 0.5 Hz)")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _report(
    results: dict[str, Any],
    plan: dict[str, Any],
    search: list[Response],
    rows: list[dict[str, Any]],
    chosen: Response,
    quick: bool,
) -> str:
    ku, tu = results["ultimate_gain"], results["ultimate_period_s"]
    lines = [
        "# Exercise 1: tune the PID",
        "",
        "*The tutorial: start with Kp = 50, Ki = 0, Kd = 0. Increase Kp until oscillation, then add Kd, "
        "then Ki. Compare responses.*",
        "",
        "Every run below is the whole graph (simulator, motor, sensor, controller, planner as five "
        "processes) in sim-time lockstep, so the same seed gives the same figures. The controller is the "
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
    ]
    cells = []
    for index, response in enumerate(search):
        f = response.figures
        cells.append(
            [
                str(index + 1),
                fmt(f["kp"], "{:.4g}"),
                fmt(f["amplitude_early_rad"], "{:.3f}"),
                fmt(f["amplitude_late_rad"], "{:.3f}"),
                fmt(f["growth_per_s"], "{:+.3f}"),
                fmt(f["period_s"], "{:.3f}"),
                "oscillates on" if f["sustained"] else "decays",
            ]
        )
    lines += [
        table(
            [
                "run",
                "Kp [N·m/rad]",
                "amplitude, first s [rad]",
                "amplitude, last s [rad]",
                "growth [1/s]",
                "period [s]",
                "verdict",
            ],
            cells,
        ),
        "",
    ]
    lines += [
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
    ]
    lines += [
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
    ]
    cells = []
    for row in rows:
        cells.append(
            [
                row["label"],
                fmt(row["kp"], "{:.3g}"),
                fmt(row["ki"], "{:.3g}"),
                fmt(row["kd"], "{:.3g}"),
                fmt(row["overshoot_pct"], "{:.1f}"),
                fmt(row["overshoot_final_pct"], "{:.1f}"),
                fmt(row["settling_time_s"], "{:.2f}", f"not in {plan['stage_after_s']:g} s"),
                fmt(row["steady_state_error_rad"], "{:.4f}"),
                fmt(row["peak_torque_nm"], "{:.2f}"),
            ]
        )
    lines += [
        table(
            [
                "run",
                "Kp",
                "Ki",
                "Kd",
                "overshoot of target [%]",
                "overshoot of final value [%]",
                "settling 2 % [s]",
                "steady-state error [rad]",
                "peak torque [N·m]",
            ],
            cells,
        ),
        "",
    ]
    lines += [
        "## The gains chosen",
        "",
        table(
            [
                "",
                "Kp [N·m/rad]",
                "Ki [N·m/(rad·s)]",
                "Kd [N·m·s/rad]",
                "step overshoot [%]",
                "settling 2 % [s]",
                "steady-state error [rad]",
                "sine RMS error [rad]",
            ],
            [
                [
                    "chosen",
                    fmt(results["kp"], "{:.3g}"),
                    fmt(results["ki"], "{:.3g}"),
                    fmt(results["kd"], "{:.3g}"),
                    fmt(results["step_overshoot_pct"], "{:.1f}"),
                    fmt(results["step_settling_time_s"], "{:.2f}", f"not in {plan['stage_after_s']:g} s"),
                    fmt(results["step_steady_state_error_rad"], "{:.4f}"),
                    fmt(results["sine_tracking_rms_rad"], "{:.4f}"),
                ]
            ]
            + (
                [
                    [
                        "the tutorial's",
                        "50",
                        "10",
                        "5",
                        fmt(results["tutorial_step_overshoot_pct"], "{:.1f}"),
                        fmt(results["tutorial_step_settling_time_s"], "{:.2f}", f"not in {plan['stage_after_s']:g} s"),
                        fmt(results["tutorial_step_steady_state_error_rad"], "{:.4f}"),
                        fmt(results["tutorial_sine_tracking_rms_rad"], "{:.4f}"),
                    ]
                ]
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
    return "\n".join(lines)


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


EXERCISE = Exercise("tune", "tune the PID: Kp until it oscillates (Ku, Tu), then Kd, then Ki", run, steps)
