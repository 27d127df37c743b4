"""The search on the batch harness alone (no ROS): Latin-hypercube samples of the
searched parameters over a wide log-scaled box, then rounds of samples around
the best so far, each round narrower; a gain set is simulated only if it passes
the robustness screen (``margins.screen``). Also the plan of the whole verb:
how many samples, how long each simulation and each real run."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.experiments.autotune.margins import (
    MIN_DELAY_PERIODS,
    MIN_GAIN_MARGIN_DB,
    MIN_PHASE_MARGIN_DEG,
    screen,
)
from robot_controller.experiments.autotune.problem import SEED, Problem


@dataclass(frozen=True)
class Plan:
    first: int  #: Latin-hypercube samples of the first round
    rounds: tuple[tuple[int, float], ...]  #: refinement rounds: (samples, σ of the spread around the best, decades)
    duration_s: float  #: simulated per gain set (2 s warm-up included)
    real_s: float  #: each real lockstep sine run, sim seconds


def plan(quick: bool) -> Plan:
    if quick:
        return Plan(first=2048, rounds=((256, 0.25), (256, 0.1)), duration_s=4.0, real_s=3.0)
    return Plan(
        first=8192, rounds=((1024, 0.3), (1024, 0.15), (1024, 0.07), (1024, 0.03)), duration_s=10.0, real_s=10.0
    )


def steps(quick: bool = False) -> int:
    """How many times ``tune()`` calls ``progress``: each search round, then the two real runs."""
    return 1 + len(plan(quick).rounds) + 2


@dataclass
class Candidates:
    """Gain sets that met every margin: the searched parameters (log10), their gains, their batch RMS."""

    log_params: np.ndarray  #: (m, 3)
    gains: np.ndarray  #: (m, 3): Kp, Ki, Kd
    rms: np.ndarray  #: (m,), rad


def latin_hypercube(rng: np.random.Generator, samples: int, box: dict[str, tuple[float, float]]) -> np.ndarray:
    """``samples`` points of the box, one in each of ``samples`` equal slices of every axis."""
    low = np.array([b[0] for b in box.values()])
    high = np.array([b[1] for b in box.values()])
    dims = len(box)
    cells = np.column_stack([rng.permutation(samples) for _ in range(dims)])
    unit = (cells + rng.random((samples, dims))) / samples
    return low + unit * (high - low)


@dataclass
class SearchResult:
    problem: Problem
    best_values: np.ndarray  #: the searched parameters chosen (Kp, Ki, Kd; or lqr_q), as written
    best_gains: np.ndarray  #: Kp, Ki, Kd
    best_rms: float
    evaluated: int  #: gain sets whose margins were computed
    robust: int  #: … of which met every margin (and were simulated)
    rounds: list[dict[str, float]]
    history: Candidates  #: every robust set simulated (for the plot)


def search(
    params: cfg.Params, *, quick: bool = False, progress: Callable[[str], None] | None = None, seed: int = SEED
) -> SearchResult:
    """The search on the batch harness alone (no ROS): the most accurate robust gains found."""
    problem = Problem(params)
    settings = plan(quick)
    rng = np.random.default_rng(seed)
    low = np.array([b[0] for b in problem.box.values()])
    high = np.array([b[1] for b in problem.box.values()])
    best_log, best_rms = None, math.inf
    evaluated = robust_count = 0
    rounds: list[dict[str, float]] = []
    kept = Candidates(np.zeros((0, 3)), np.zeros((0, 3)), rms=np.zeros(0))
    top: np.ndarray = np.zeros((0, 3))
    schedule = [(settings.first, None)] + list(settings.rounds)
    for index, (samples, spread) in enumerate(schedule):
        if progress is not None:
            progress(
                f"search round {index + 1} of {len(schedule)}: {samples} gain sets"
                + ("" if spread is None else f" within ±{spread:g} decades of the best")
            )
        if spread is None or len(top) == 0:
            log_params = latin_hypercube(rng, samples, problem.box)
            if index == 0:  # the configured gains compete too
                log_params[0] = problem.current_log_params()
        else:
            centres = top[rng.integers(0, len(top), samples)]
            log_params = np.clip(centres + rng.normal(0.0, spread, centres.shape), low - 1.0, high + 1.0)
        gains = problem.gains_of(log_params)
        margins, ok = screen(problem, gains)
        evaluated += samples
        robust_count += int(np.count_nonzero(ok))
        rms = np.full(samples, np.inf)
        if np.any(ok):
            rms[ok] = problem.tracking_rms(gains[ok], settings.duration_s, seed)
        kept = Candidates(
            np.vstack([kept.log_params, log_params[ok]]),
            np.vstack([kept.gains, gains[ok]]),
            rms=np.concatenate([kept.rms, rms[ok]]),
        )
        finite = np.isfinite(kept.rms)
        if np.any(finite):
            order = np.argsort(np.where(finite, kept.rms, np.inf))
            top = kept.log_params[order[:8]]
            if kept.rms[order[0]] < best_rms:
                best_rms, best_log = float(kept.rms[order[0]]), kept.log_params[order[0]]
        rounds.append({"samples": samples, "robust": int(np.count_nonzero(ok)), "best_rms_rad": best_rms})
    if best_log is None:
        raise RuntimeError(
            "tune: no gain set in the search met the margins "
            f"(gain ≥ {MIN_GAIN_MARGIN_DB:g} dB, phase ≥ {MIN_PHASE_MARGIN_DEG:g}°, delay ≥ "
            f"{MIN_DELAY_PERIODS} periods)"
        )
    # The overlay is rounded: the result is what the rounded values give.
    best_values = problem.rounded(best_log)
    best_gains = problem.gains_of_values(best_values)[0]
    _, ok = screen(problem, best_gains[None])
    if not ok[0]:  # rounding to 4 digits moved it across a margin: keep the exact values
        best_values = 10.0**best_log
        best_gains = problem.gains_of_values(best_values)[0]
    return SearchResult(problem, best_values, best_gains, best_rms, evaluated, robust_count, rounds, kept)
