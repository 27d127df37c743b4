"""Exercise 1, "Tune the PID" (``exercise tune``), by Ziegler and Nichols on the real graph: Kp alone until the
loop oscillates on (:func:`kp_search`, judged by :func:`oscillation`) for the ultimate gain Ku and period Tu, beside
the sampled arm model's own (:func:`model_ultimate`); the classic rule's PID, then Kd until the overshoot is gone, Ki
until the steady-state error is gone; the gains chosen on the sine."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.core.laws import robustness
from robot_controller.experiments.exercises.ziegler_nichols.report import plot_sine, plot_stages, report_text
from robot_controller.experiments.exercises.ziegler_nichols.settings import (
    KP_START,
    KU_STEP_RAD,
    NOISE_FLOOR_RAD,
    OVERSHOOT_MAX_PCT,
    PRESET,
    SSE_MAX_FRACTION,
    STAGE_LEAD_S,
    STAGE_STEP_RAD,
    SUSTAINED_GROWTH_PER_S,
    TUTORIAL_GAINS,
    make_plan,
    steps,
    with_gains,
)
from robot_controller.experiments.loop_model import plant_loop
from robot_controller.experiments.reporting import Progress, write_report, write_results
from robot_controller.experiments.step import SEED, Response, sine_params, sine_run, step_run, store

__all__ = ["choose_ki", "model_ultimate", "oscillation", "run", "steps"]


def oscillation(response: Response, *, settle_s: float = 0.3, window_s: float = 1.0) -> dict[str, float]:
    """How the oscillation after a step evolves, on the TRUE angle: its amplitude (half the peak-to-peak)
    in the first and the last ``window_s``, ``growth_per_s`` = ln(late / early) / their distance,
    ``sustained`` (not decaying, above the noise) and ``period_s`` (mean spacing of upward crossings)."""
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
    """Ku and Tu of the sampled arm model under P alone: the Kp whose poles reach the unit circle, their period."""
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


def kp_search(
    base: cfg.Params, out: Path, plan: dict[str, Any], results: dict[str, Any], *, progress: Progress, seed: int
) -> tuple[list[Response], float, float]:
    """Kp alone on a small step (in ``out/kp_search``), halved or doubled from the tutorial's until bracketed,
    then bisected: the runs (their figures also into ``results``), the largest Kp that decayed, the smallest not."""
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
            with_gains(base, kp, 0.0, 0.0),
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
    return search, low, high


def run(out: Path, *, quick: bool = False, progress: Progress = print, seed: int = SEED) -> dict[str, Any]:
    out.mkdir(parents=True, exist_ok=True)
    plan = make_plan(quick)
    base = cfg.load_stack(PRESET)
    results: dict[str, Any] = {"quick": int(quick), "seed": seed}
    rows: list[dict[str, Any]] = []  # every run, for the tables

    # 1. Kp alone, until it oscillates without end.
    search, low, high = kp_search(base, out, plan, results, progress=progress, seed=seed)
    at_ku = next(r for r in search if r.figures["kp"] == high)
    ku, tu = high, at_ku.figures["period_s"]
    model_ku, model_tu = model_ultimate(base)
    results.update(ultimate_gain=ku, ultimate_period_s=tu, ultimate_gain_bracket_low=low)
    results.update(model_ultimate_gain=model_ku, model_ultimate_period_s=model_tu)

    # 2. Ziegler–Nichols' classic PID from Ku, Tu.
    zn = (0.6 * ku, 1.2 * ku / tu, 0.075 * ku * tu)
    results.update({"zn_kp": zn[0], "zn_ki": zn[1], "zn_kd": zn[2]})
    stage_kwargs = {"amplitude": STAGE_STEP_RAD, "lead_s": STAGE_LEAD_S, "after_s": plan["stage_after_s"], "seed": seed}

    def stage(row: str, gains: tuple[float, float, float], folder: Path, label: str) -> Response:
        response = step_run(with_gains(base, *gains), out / folder, label, **stage_kwargs)
        rows.append({"label": row, "kp": gains[0], "ki": gains[1], "kd": gains[2], **response.figures})
        return response

    zn_response = None
    if plan["zn_run"]:
        progress(f"Ziegler–Nichols PID: Kp {zn[0]:.3g}, Ki {zn[1]:.3g}, Kd {zn[2]:.3g}")
        zn_response = stage("Ziegler–Nichols PID", zn, Path("ziegler_nichols"), "Ziegler–Nichols")
        _store(results, "zn_step", zn_response.figures)

    # 3. Then Kd, until the overshoot is gone.
    kp = zn[0]
    kd_runs: list[Response] = []
    kd = None
    for index, factor in enumerate(plan["kd_factors"]):
        candidate = zn[2] * factor
        progress(f"then Kd: Kp {kp:.3g}, Kd {candidate:.3g}, Ki 0")
        gains = (kp, 0.0, candidate)
        response = stage(f"Kd stage {index + 1}", gains, Path("kd_stage", f"run_{index + 1}"), f"Kd {candidate:.3g}")
        response.figures["kd"] = candidate
        kd_runs.append(response)
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
        gains = (kp, candidate, kd)
        response = stage(f"Ki stage {index + 1}", gains, Path("ki_stage", f"run_{index + 1}"), f"Ki {candidate:.3g}")
        response.figures["ki"] = candidate
        ki_runs.append(response)
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
        with_gains(sine_params(base), kp, ki, kd), out / "sine_chosen", "chosen", duration_s=plan["sine_s"], seed=seed
    )
    results["sine_tracking_rms_rad"] = sine.figures["tracking_rms_rad"]
    results["sine_tracking_max_rad"] = sine.figures["tracking_max_rad"]
    tutorial_step = tutorial_sine = None
    if plan["tutorial_runs"]:
        progress("the tutorial's gains (50, 10, 5): step")
        tutorial_step = step_run(
            with_gains(base, *TUTORIAL_GAINS), out / "tutorial_step", "tutorial (50, 10, 5)", **stage_kwargs
        )
        _store(results, "tutorial_step", tutorial_step.figures)
        progress("the tutorial's gains (50, 10, 5): sine")
        tutorial_sine = sine_run(
            with_gains(sine_params(base), *TUTORIAL_GAINS),
            out / "sine_tutorial",
            "tutorial",
            duration_s=plan["sine_s"],
            seed=seed,
        )
        results["tutorial_sine_tracking_rms_rad"] = tutorial_sine.figures["tracking_rms_rad"]

    A, B, dt = plant_loop(base)
    row = robustness.pid_gain_row(kp, ki, kd)
    results.update(robustness.margins(A, B, row, dt).as_dict("margin_"))
    results["margin_delay_periods"] = int(robustness.delay_margin_periods(A, B, row)[0])
    results = write_results(out, results)
    plot_stages(out / "tune.png", search, zn_response, kd_runs, ki_runs, chosen, tutorial_step, ku, kp, kd)
    plot_sine(out / "tune_sine.png", sine, tutorial_sine)
    write_report(out, report_text(results, plan, search, rows, quick))
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
    keys = "overshoot_pct overshoot_final_pct settling_time_s rise_time_s steady_state_error_rad peak_torque_nm"
    store(results, prefix, figures, (*keys.split(), "saturated_s"))
