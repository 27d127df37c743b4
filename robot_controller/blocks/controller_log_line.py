"""The tutorial's once-a-period line, ``target=…, actual=…, error=…, torque=…``: when it is said and what it says.

Said once in every logging period, as the tutorial's is, but not at the same instant of each: a trajectory whose
period divides the logging period (the 0.5 Hz sine against a line a second) would be seen at one phase only (in
sim time, its zero crossing every time: the arm looks dead). The instant moves ``PHASE_STEP`` of a period later each
period, and back once it nears the period's end, so lines are never closer than ``1 - PHASE_STEP`` periods apart and
a periodic motion is seen across its range."""

from __future__ import annotations

import math
from collections.abc import Iterable

#: How far (in logging periods) the instant of the line moves from one period to the next: not a simple fraction,
#: so that no short trajectory period is sampled at a few phases only.
PHASE_STEP = 0.13
#: The latest a line comes in its period (a fraction of it): a late tick still says it within its period.
LATEST_PHASE = 0.9
TIME_EPS_S = 1e-9  # ticks land on a period's instant within rounding


def phase_in_period(k: int) -> float:
    """Where in its logging period (0 … ``LATEST_PHASE``) the ``k``-th line is said: ``k * PHASE_STEP`` folded
    back at each end."""
    walked = math.fmod(k * PHASE_STEP, 2.0 * LATEST_PHASE)
    return walked if walked <= LATEST_PHASE else 2.0 * LATEST_PHASE - walked


class LogSchedule:
    """Once in each logging period, at the instant :func:`phase_in_period` gives it; the first at the first tick.

    :param period_s: the logging period (``log_period_s``), s
    """

    def __init__(self, period_s: float) -> None:
        self.period_s = period_s
        self.start_s: float | None = None  # when period 0 began (the first tick, or a restart)
        self.index = 0  # the period whose line is due next

    def due(self, now_s: float, period_s: float | None = None) -> bool:
        """Whether the line is said at this tick (``now_s``, s); ``period_s``: the period in force now (a changed
        one starts afresh from the last line said)."""
        if period_s is not None and period_s != self.period_s:
            if self.start_s is not None:
                self.start_s = self.said_at_s()
                self.index = 1
            self.period_s = period_s
        if self.start_s is None:
            self.start_s = now_s
        if now_s < self.instant_s(self.index) - TIME_EPS_S:
            return False
        if self.instant_s(self.index + 1) <= now_s + TIME_EPS_S:
            # A gap in the ticks (a frozen host) spans more than one line's instant: one line, now, and the
            # periods start afresh from it.
            self.start_s, self.index = now_s, 0
        self.index += 1
        return True

    def instant_s(self, k: int) -> float:
        """When the ``k``-th line is due, s."""
        return self.start_s + (k + phase_in_period(k)) * self.period_s

    def said_at_s(self) -> float:
        """When the last line was due (the first period's start before any)."""
        return self.instant_s(self.index - 1) if self.index > 0 else self.start_s


Values = Iterable[float]


def line(reference: Values, measured: Values, error: Values, command: Values) -> str:
    """``target=…, actual=…, error=…, torque=…`` (``actual``: the controller's estimate), three decimals, a value per
    joint separated by commas."""
    return f"target={_fmt(reference)}, actual={_fmt(measured)}, error={_fmt(error)}, torque={_fmt(command)}"


def _fmt(values: Values) -> str:
    return ",".join(f"{v:.3f}" for v in values)
