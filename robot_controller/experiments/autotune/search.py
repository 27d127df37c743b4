"""The search ``tune`` runs on any problem: a Latin hypercube over its box, then rounds of samples
around the best robust candidates, narrower each round (:meth:`SearchProblem.evaluate` judges them)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

SEED = 0
ROBUST, FAILED, UNCHECKED = 1, 0, -1  #: a candidate's verdict


@dataclass(frozen=True)
class SearchPlan:
    first: int  #: Latin-hypercube samples of the first round
    rounds: tuple[tuple[int, float], ...]  #: refinement rounds: (samples, σ of the spread around the best)
    duration_s: float  #: each candidate's sine run (2 s warm-up included)
    check_s: float  #: each before/after check run, s
    max_checks: int = 0  #: robustness checks per round at most, once one is robust (a black box's)


class SearchProblem(Protocol):
    low: np.ndarray  #: the first round's box, in search coordinates
    high: np.ndarray
    clip_low: np.ndarray  #: the refinement rounds' bounds
    clip_high: np.ndarray
    centres: int  #: the refinement rounds spread around this many best robust candidates

    def start(self) -> np.ndarray: ...
    def values(self, points: np.ndarray) -> np.ndarray: ...
    def round_text(self, samples: int, spread: float | None) -> str: ...
    def evaluate(
        self, values: np.ndarray, plan: SearchPlan, seed: int, best_rms: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...
    def passes(self, values: np.ndarray, seed: int) -> bool: ...
    def nothing_robust(self) -> str: ...


@dataclass
class Candidates:
    """Every candidate run: coordinates, values, what the problem kept (the gains), RMS (rad), verdict."""

    points: np.ndarray
    values: np.ndarray
    detail: np.ndarray
    rms: np.ndarray
    verdict: np.ndarray


@dataclass
class SearchResult:
    problem: Any
    best_values: np.ndarray  #: the searched parameters chosen, as written (4 significant figures)
    best_rms: float  #: rad, on the search's runs
    evaluated: int  #: candidates evaluated
    checked: int  #: … whose robustness was checked
    robust: int  #: … of which were robust
    rounds: list[dict[str, float]]
    history: Candidates


def latin_hypercube(rng: np.random.Generator, samples: int, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """``samples`` points of the box, one in each of ``samples`` equal slices of every axis."""
    dims = len(low)
    cells = np.column_stack([rng.permutation(samples) for _ in range(dims)])
    unit = (cells + rng.random((samples, dims))) / samples
    return low + unit * (high - low)


def search(
    problem: SearchProblem, plan: SearchPlan, *, progress: Callable[[str], None] | None = None, seed: int = SEED
) -> SearchResult:
    """The best-tracking robust candidate, rounded as the parameter file gets it.

    :raises RuntimeError: no candidate was robust
    """
    rng = np.random.default_rng(seed)
    best_point, best_rms = None, math.inf
    history: list[tuple[np.ndarray, ...]] = []
    rounds: list[dict[str, float]] = []
    top = np.zeros((0, len(problem.low)))
    kept_points, kept_rms = top, np.zeros(0)
    schedule = [(plan.first, None), *plan.rounds]
    for index, (samples, spread) in enumerate(schedule):
        if progress is not None:
            progress(f"search round {index + 1} of {len(schedule)}: " + problem.round_text(samples, spread))
        if spread is None or len(top) == 0:
            points = latin_hypercube(rng, samples, problem.low, problem.high)
            if index == 0:  # the configured values compete too
                points[0] = problem.start()
        else:
            centres = top[rng.integers(0, len(top), samples)]
            points = np.clip(centres + rng.normal(0.0, spread, centres.shape), problem.clip_low, problem.clip_high)
        values = problem.values(points)
        rms, verdict, detail = problem.evaluate(values, plan, seed, best_rms)
        history.append((points, values, detail, rms, verdict))
        robust = verdict == ROBUST
        kept_points, kept_rms = np.vstack([kept_points, points[robust]]), np.concatenate([kept_rms, rms[robust]])
        finite = np.isfinite(kept_rms)
        if np.any(finite):
            order = np.argsort(np.where(finite, kept_rms, np.inf))
            top = kept_points[order[: problem.centres]]
            if kept_rms[order[0]] < best_rms:
                best_rms, best_point = float(kept_rms[order[0]]), kept_points[order[0]]
        rounds.append({"samples": samples, "robust": int(np.count_nonzero(robust)), "best_rms_rad": best_rms})
    if best_point is None:
        raise RuntimeError(problem.nothing_robust())
    exact = problem.values(best_point[None])[0]
    best_values = np.array([round_figures(v) for v in exact])
    if not problem.passes(best_values, seed):  # rounding moved it across a margin: keep the exact values
        best_values = exact
    every = Candidates(*(np.concatenate([round_[i] for round_ in history]) for i in range(5)))
    checked = int(np.count_nonzero(every.verdict != UNCHECKED))
    robust_count = int(np.count_nonzero(every.verdict == ROBUST))
    return SearchResult(problem, best_values, best_rms, len(every.rms), checked, robust_count, rounds, every)


def round_figures(value: float, digits: int = 4) -> float:
    """``value`` to ``digits`` significant figures."""
    if value == 0 or not math.isfinite(value):
        return float(value)
    return float(round(value, digits - 1 - int(math.floor(math.log10(abs(value))))))
