"""The search of ``tune --controller``: a Latin hypercube over the searched ranges, then rounds
of samples around the best robust candidates, narrower each round (:func:`search`); its size
in the quick and full forms (:func:`plan`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from robot_controller.experiments.autotune.law_problem import CASES, LawProblem
from robot_controller.experiments.autotune.problem import SEED
from robot_controller.experiments.autotune.search import latin_hypercube


@dataclass(frozen=True)
class LawPlan:
    first: int  #: Latin-hypercube samples of the first round
    rounds: tuple[tuple[int, float], ...]  #: (samples, σ of the spread around the best robust, fraction of the range)
    duration_s: float  #: each candidate's sine run, s (2 s warm-up included)
    max_checks: int  #: robustness checks per round at most (best tracking first)
    check_s: float  #: the before/after check's sine run, s


def plan(quick: bool) -> LawPlan:
    if quick:
        return LawPlan(first=16, rounds=((8, 0.12), (8, 0.05)), duration_s=4.0, max_checks=3, check_s=10.0)
    return LawPlan(first=48, rounds=((16, 0.15), (16, 0.07), (16, 0.03)), duration_s=10.0, max_checks=6, check_s=20.0)


def steps(quick: bool = False) -> int:
    """How many times :func:`tune_law` calls ``progress``: each search round, then the check."""
    return 1 + len(plan(quick).rounds) + 1


@dataclass
class LawSearch:
    problem: LawProblem
    best_values: np.ndarray  #: as written (4 significant figures)
    best_rms: float  #: rad, on the search's runs
    evaluated: int  #: candidates run
    checked: int  #: … whose robustness was checked
    robust: int  #: … of which passed every case
    rounds: list[dict[str, float]]
    history: list[tuple[np.ndarray, float, bool | None]] = field(default_factory=list)  #: values, RMS, robust?


def search(
    problem: LawProblem, *, quick: bool = False, progress: Callable[[str], None] | None = None, seed: int = SEED
) -> LawSearch:
    """The best-tracking values that pass every robustness case, among those run."""
    settings = plan(quick)
    rng = np.random.default_rng(seed)
    unit_box = {k.name: (0.0, 1.0) for k in problem.knobs}
    best_units, best_rms = None, math.inf
    robust_units: list[tuple[float, np.ndarray]] = []
    history: list[tuple[np.ndarray, float, bool | None]] = []
    rounds: list[dict[str, float]] = []
    evaluated = checked = robust_count = 0
    schedule = [(settings.first, None), *settings.rounds]
    for index, (samples, spread) in enumerate(schedule):
        if progress is not None:
            progress(
                f"search round {index + 1} of {len(schedule)}: {samples} candidates on the in-process loop"
                + ("" if spread is None else f" around the best robust (σ {spread:g} of each range)")
            )
        if spread is None or not robust_units:
            units = latin_hypercube(rng, samples, unit_box)
            if index == 0:  # the configured values compete too
                units[0] = [k.unit(v) for k, v in zip(problem.knobs, problem.current(), strict=True)]
        else:
            centres = np.array([u for _, u in sorted(robust_units, key=lambda r: r[0])[:3]])
            picked = centres[rng.integers(0, len(centres), samples)]
            units = np.clip(picked + rng.normal(0.0, spread, picked.shape), 0.0, 1.0)
        values = _values(problem, units)
        rms = np.array([problem.tracking_rms(v, settings.duration_s, seed) for v in values])
        evaluated += samples
        verdicts: list[bool | None] = [None] * samples
        cap = settings.max_checks if robust_units else samples  # none robust yet: down the whole round
        for i in np.argsort(rms)[:cap]:
            if not rms[i] < best_rms:
                break  # no better than the best robust: not worth its checks
            checked += 1
            verdicts[i] = problem.robust(values[i], seed)
            if verdicts[i]:
                robust_count += 1
                robust_units.append((float(rms[i]), units[i]))
                best_units, best_rms = units[i], float(rms[i])
                break  # the round's best robust one: the others track worse
        history += [(v, float(r), ok) for v, r, ok in zip(values, rms, verdicts, strict=True)]
        rounds.append({"samples": samples, "best_rms_rad": best_rms})
    if best_units is None:
        raise RuntimeError(
            f"tune: no candidate for {problem.spec} let a push die away in every case "
            f"({', '.join(c.name for c in CASES)}); see the law's ranges"
        )
    exact = _values(problem, best_units[None])[0]
    best_values = np.array([_round(v) for v in exact])  # as the parameter file gets them
    if not problem.robust(best_values, seed):  # rounding moved it across a case's edge: keep the exact values
        best_values = exact
    return LawSearch(problem, best_values, best_rms, evaluated, checked, robust_count, rounds, history)


def _values(problem: LawProblem, units: np.ndarray) -> np.ndarray:
    units = np.atleast_2d(units)
    return np.column_stack([k.value(units[:, j]) for j, k in enumerate(problem.knobs)])


def _round(value: float, digits: int = 4) -> float:
    if value == 0 or not math.isfinite(value):
        return float(value)
    return float(round(value, digits - 1 - int(math.floor(math.log10(abs(value))))))
