"""Stage 1 of exercise 1, Kp alone: the ultimate gain Ku and period Tu on the real graph
(:func:`kp_search`, judged by :func:`oscillation`) and the sampled arm model's own (:func:`model_ultimate`)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.core.laws import robustness
from robot_controller.experiments.exercises.ziegler_nichols.settings import (
    KP_START,
    KU_STEP_RAD,
    NOISE_FLOOR_RAD,
    SUSTAINED_GROWTH_PER_S,
    with_gains,
)
from robot_controller.experiments.loop_model import plant_loop
from robot_controller.experiments.reporting import Progress
from robot_controller.experiments.runs import Response, step_run


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
