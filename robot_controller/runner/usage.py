"""CPU time (percent of one core) and resident memory of a run's processes from ``/proc``, sampled once
after start-up and once at the end."""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

from robot_controller.runner.processes import Child, say

_TICKS_PER_S = os.sysconf("SC_CLK_TCK")
_PAGE_BYTES = os.sysconf("SC_PAGE_SIZE")
# Measured from this long after the loop closes (start-up allocations and imports are not its running cost).
USAGE_WARMUP_S = 2.0


@dataclass(frozen=True)
class ProcessUsage:
    cpu_s: float  #: user + system CPU seconds since the process started
    rss_mb: float  #: resident set size, MiB


def sample(pid: int) -> ProcessUsage | None:
    """The process's CPU time and memory now; None if it is gone."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        with open(f"/proc/{pid}/statm") as f:
            resident_pages = int(f.read().split()[1])
    except (OSError, IndexError, ValueError):
        return None
    # After the ")" of the command name: fields[11] is utime, fields[12] stime (stat(5) fields 14, 15).
    return ProcessUsage(
        cpu_s=(int(fields[11]) + int(fields[12])) / _TICKS_PER_S, rss_mb=resident_pages * _PAGE_BYTES / 2**20
    )


def usage(
    start: dict[str, ProcessUsage | None], end: dict[str, ProcessUsage | None], wall_s: float
) -> dict[str, float]:
    """``cpu_pct_<name>`` (% of one core), ``rss_mb_<name>``, ``rss_growth_mb_<name>`` and ``cpu_pct_total``."""
    out: dict[str, float] = {}
    total = 0.0
    for name, first in start.items():
        last = end.get(name)
        if first is None or last is None or wall_s <= 0:
            continue
        pct = 100.0 * (last.cpu_s - first.cpu_s) / wall_s
        out[f"cpu_pct_{name}"] = round(pct, 2)
        out[f"rss_mb_{name}"] = round(last.rss_mb, 1)
        out[f"rss_growth_mb_{name}"] = round(last.rss_mb - first.rss_mb, 2)
        total += pct
    out["cpu_pct_total"] = round(total, 2)
    return out


class UsageMeter:
    """Samples every child (and this launcher) once at ``start_at`` and once at the end. The
    observers (the viewer) are measured apart, outside ``cpu_pct_total``; one that exits is said once."""

    def __init__(self, children: list[Child], start_at: float, observers: list[Child] = ()) -> None:
        self.pids = {c.name: c.process.pid for c in children}
        self.observers = list(observers)
        self.start_at = start_at
        self.first: dict[str, ProcessUsage | None] | None = None
        self.first_time = 0.0
        self.said: set[str] = set()

    def _sample(self) -> dict[str, ProcessUsage | None]:
        out = {name: sample(pid) for name, pid in self.pids.items()}
        out.update({c.name: sample(c.process.pid) for c in self.observers})
        out["launcher"] = sample(os.getpid())
        return out

    def forget(self, name: str) -> None:
        """A process that was replaced (respawned): its share is not measured."""
        self.pids.pop(name, None)
        if self.first is not None:
            self.first.pop(name, None)

    def poll(self) -> None:
        if self.first is None and time.monotonic() >= self.start_at:
            self.first, self.first_time = self._sample(), time.monotonic()
        for child in self.observers:
            if child.name not in self.said and child.process.poll() is not None:
                self.said.add(child.name)
                say(f"{child.name} exited (code {child.process.returncode}): no live view; the run goes on")

    def finish(self) -> dict[str, float]:
        if self.first is None:
            return {}
        last, wall_s = self._sample(), time.monotonic() - self.first_time
        apart = {c.name for c in self.observers}
        figures = usage({n: s for n, s in self.first.items() if n not in apart}, last, wall_s)
        observed = usage({n: s for n, s in self.first.items() if n in apart}, last, wall_s)
        return figures | {k: v for k, v in observed.items() if k != "cpu_pct_total"}
