"""CPU time and resident memory of processes, read from ``/proc`` (Linux).

The launcher samples each child at the start and end of the measured window:
CPU as percent of one core over that window (user + system, all threads),
memory as resident set size, so a run reports what each node costs and
whether it grows.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

_TICKS_PER_S = os.sysconf("SC_CLK_TCK")
_PAGE_BYTES = os.sysconf("SC_PAGE_SIZE")


@dataclass(frozen=True)
class Sample:
    cpu_s: float  #: user + system CPU seconds since the process started
    rss_mb: float  #: resident set size, MiB


def sample(pid: int) -> Sample | None:
    """The process's CPU time and memory now; None if it is gone."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        with open(f"/proc/{pid}/statm") as f:
            resident_pages = int(f.read().split()[1])
    except (OSError, IndexError, ValueError):
        return None
    # After the ")" of the command name: fields[11] is utime, fields[12] stime (stat(5) fields 14, 15).
    return Sample(cpu_s=(int(fields[11]) + int(fields[12])) / _TICKS_PER_S, rss_mb=resident_pages * _PAGE_BYTES / 2**20)


def self_sample() -> Sample:
    """This process (all its threads)."""
    found = sample(os.getpid())
    assert found is not None
    return found


def usage(start: dict[str, Sample | None], end: dict[str, Sample | None], wall_s: float) -> dict[str, float]:
    """``cpu_pct_<name>`` (percent of one core), ``rss_mb_<name>`` and
    ``rss_growth_mb_<name>`` per process, and ``cpu_pct_total``."""
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
