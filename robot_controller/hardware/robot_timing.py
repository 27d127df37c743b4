"""How the robot's clock went over a run, from each tick's record: the controller's time per tick against the robot's
period (p50, p99, max), the periods the robot counted without a command, its ``control_command_success_rate`` (the
share of the last 100 commands it took in time: its low once 100 have gone), and the share of the time the
hypervisor took from this host (steal) meanwhile."""

from __future__ import annotations

import numpy as np

#: commands libfranka's ``control_command_success_rate`` is taken over: before as many, it counts the start's
SUCCESS_WINDOW = 100


def steal_ticks() -> tuple[int, int]:
    """The host's CPU time so far, (stolen by the hypervisor, all), in clock ticks (``/proc/stat``)."""
    try:
        with open("/proc/stat") as stat:
            fields = [int(x) for x in stat.readline().split()[1:]]
    except (OSError, ValueError):
        return 0, 0
    return (fields[7] if len(fields) > 7 else 0), sum(fields)


class RobotTiming:
    """Each tick's compute time, the robot's success rate and the periods it missed, taken as they come."""

    def __init__(self) -> None:
        self._compute: list[float] = []
        self._rates: list[float] = []
        self.missed = 0
        self._steal_start = steal_ticks()

    def take(self, compute_s: float, success_rate: float, missed: float) -> None:
        self._compute.append(compute_s)
        self._rates.append(success_rate)
        self.missed += int(missed)

    def figures(self) -> dict[str, float]:
        """The run's figures so far (:func:`timing_figures`) and ``host_steal_pct``."""
        stolen, total = (b - a for a, b in zip(self._steal_start, steal_ticks(), strict=True))
        figures = timing_figures(np.asarray(self._compute), np.asarray(self._rates), self.missed)
        figures["host_steal_pct"] = 100.0 * stolen / total if total > 0 else float("nan")
        return figures


def timing_figures(compute_s: np.ndarray, success_rates: np.ndarray, missed: int) -> dict[str, float]:
    """From each tick's compute time and the robot's success rate, and the periods it missed (NaN before any tick):
    ``tick_compute_{p50,p99,max}_ms``, ``robot_missed_cycles``, ``command_success_rate`` (the ticks' share of the
    robot's periods), ``command_success_rate_min`` (libfranka's, its low once a window of commands has gone)."""
    ms = compute_s * 1e3
    rates = success_rates[SUCCESS_WINDOW:]
    ticks, nan = ms.size, float("nan")
    return {
        "tick_compute_p50_ms": float(np.percentile(ms, 50)) if ticks else nan,
        "tick_compute_p99_ms": float(np.percentile(ms, 99)) if ticks else nan,
        "tick_compute_max_ms": float(ms.max()) if ticks else nan,
        "robot_missed_cycles": float(missed),
        "command_success_rate": ticks / (ticks + missed) if ticks else nan,
        "command_success_rate_min": float(rates.min()) if rates.size else nan,
    }
