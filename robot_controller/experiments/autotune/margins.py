"""The margins every tuned loop keeps on the sampled loop (the feedback on ``[∫e, e, ė]``): the search's
screen of many gain sets at once, and every margin of one gain set for the report."""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from robot_controller.core.laws import robustness


class SampledLoop(Protocol):
    """The sampled loop: ``x[k+1] = A x[k] + B u[k]`` on ``[∫e, e, ė]``, period ``dt`` (s)."""

    A: np.ndarray
    B: np.ndarray
    dt: float


#: The robustness every tuned loop keeps.
MIN_GAIN_MARGIN_DB = 6.0
MIN_PHASE_MARGIN_DEG = 45.0
MIN_DELAY_PERIODS = 2
#: And no lower gain limit: the loop stays stable however much its gain drops. The torque limit is such a
#: drop (a saturated command is a smaller gain); a conditionally stable loop can then swing into a limit cycle.
UNCONDITIONALLY_STABLE = True
#: And integral action that works: the slowest closed-loop pole dies away within this time constant, so a
#: steady load the feedforward does not cancel (a payload, a push) is removed within seconds. The sine alone
#: rewards dropping the integral (with exact feedforward it has little to do there).
MAX_TIME_CONSTANT_S = 1.0


def screen(problem: SampledLoop, gains: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The margins of each gain set (rows Kp, Ki, Kd) and whether it meets every constraint."""
    rows = np.column_stack([gains[:, 1], gains[:, 0], gains[:, 2]])  # on [∫e, e, ė]
    finite = np.all(np.isfinite(rows), axis=1)
    rows = np.where(finite[:, None], rows, 0.0)
    margins = robustness.margins_batch(problem.A, problem.B, rows, problem.dt)
    ok = finite & margins["stable"]
    with np.errstate(invalid="ignore"):
        ok &= margins["gain_margin_db"] >= MIN_GAIN_MARGIN_DB
        low = margins["gain_margin_low_db"]
        ok &= (low == np.inf) if UNCONDITIONALLY_STABLE else (low >= MIN_GAIN_MARGIN_DB)
        ok &= margins["phase_margin_deg"] >= MIN_PHASE_MARGIN_DEG
    ok &= margins["spectral_radius"] <= math.exp(-problem.dt / MAX_TIME_CONSTANT_S)
    idx = np.flatnonzero(ok)
    if idx.size:
        delay = robustness.delay_margin_periods(problem.A, problem.B, rows[idx], max_periods=MIN_DELAY_PERIODS)
        ok[idx] = delay >= MIN_DELAY_PERIODS
    return margins, ok


def describe_margins(problem: SampledLoop, gains: np.ndarray) -> dict[str, float]:
    """Every margin of the loop with gains (Kp, Ki, Kd), and whether it meets the constraints (:func:`screen`'s)."""
    row = robustness.pid_gain_row(*gains)
    m = robustness.margins(problem.A, problem.B, row, problem.dt)
    delay = int(robustness.delay_margin_periods(problem.A, problem.B, row)[0])
    slowest = float(np.max(np.abs(robustness.poles(problem.A, problem.B, row))))
    tau = -problem.dt / math.log(slowest) if 0 < slowest < 1 else math.inf
    meets = bool(screen(problem, np.asarray(gains, dtype=float)[None])[1][0])
    return {
        "stable": int(m.stable),
        "spectral_radius": m.spectral_radius,
        "slowest_time_constant_s": tau,
        "gain_margin_db": m.gain_margin_db,
        "gain_margin_low_db": m.gain_margin_low_db,
        "phase_margin_deg": m.phase_margin_deg,
        "delay_margin_periods": delay,
        "delay_margin_s": m.delay_margin_s,
        "crossover_rad_s": m.crossover_rad_s,
        "meets_constraints": int(meets),
    }
