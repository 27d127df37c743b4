"""Where the loop's processes spent a stretch of wall time: running, or kept from running by the host.

Each stack node leaves its pid in the run's scratch folder (``COUNTS_DIR_ENV``); the paced world reads, over a
late effort's wait, how long the loop's main threads (where their executors run) waited for a CPU
(``/proc/<pid>/schedstat``'s run delay) and how long the hypervisor took the host's CPUs (``/proc/stat``'s
steal, in 10 ms steps). A wait the host filled is the host's, not the loop's own miss. Linux only; elsewhere
nothing is measured and every late effort is the loop's."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

PID_FILE_PREFIX = "pid."
_TICK_NS = 1_000_000_000 // (os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100)


def leave_pid(counts_dir: str, node_name: str) -> None:
    """Leave this process's pid for the paced world (nothing without a scratch folder)."""
    if not counts_dir:
        return
    try:
        Path(counts_dir, f"{PID_FILE_PREFIX}{node_name}").write_text(str(os.getpid()))
    except OSError:
        pass  # the figures lose this node's waits; the run does not


@dataclass(frozen=True)
class Usage:
    """Totals at one instant, ns: the loop's threads' CPU time and run-queue wait, and the host's steal."""

    cpu_ns: int
    run_wait_ns: int
    steal_ns: int

    def __sub__(self, other: Usage) -> Usage:
        return Usage(self.cpu_ns - other.cpu_ns, self.run_wait_ns - other.run_wait_ns, self.steal_ns - other.steal_ns)


def host_kept_waiting(used: Usage, late_ns: int) -> bool:
    """Whether, over a wait ``late_ns`` past the effort's due time, the host took at least that long from the
    loop (its threads waiting for a CPU, or the hypervisor's steal): then the host made the effort late."""
    return used.run_wait_ns + used.steal_ns >= late_ns


class LoopProcesses:
    """The loop's processes (every stack node, this one too) as found in ``counts_dir``."""

    def __init__(self, counts_dir: str) -> None:
        self.counts_dir = Path(counts_dir) if counts_dir else None
        self.pids: list[int] = []

    def _find(self) -> None:
        if self.counts_dir is None:
            return
        pids = []
        for path in self.counts_dir.glob(f"{PID_FILE_PREFIX}*"):
            try:
                pids.append(int(path.read_text()))
            except (OSError, ValueError):
                continue
        self.pids = sorted(set(pids))  # one process for all nodes (--single-process): read once

    def usage(self) -> Usage | None:
        """The totals now, or None where they cannot be read (not Linux, no scratch folder). Each process's main
        thread only, where its executor runs: one read a process, cheap enough for the world's pacing thread."""
        if not self.pids:
            self._find()
        cpu_ns = wait_ns = 0
        read = False
        for pid in self.pids:
            try:
                with open(f"/proc/{pid}/schedstat") as f:
                    fields = f.read().split()
            except OSError:
                self.pids = []  # one ended: found again next time (a respawned node has a new pid)
                continue
            cpu_ns, wait_ns, read = cpu_ns + int(fields[0]), wait_ns + int(fields[1]), True
        return Usage(cpu_ns, wait_ns, _steal_ns()) if read else None


def _steal_ns() -> int:
    """The hypervisor's steal over every CPU since boot, ns (``/proc/stat``'s eighth figure, in clock ticks)."""
    try:
        with open("/proc/stat") as f:
            fields = f.readline().split()
    except OSError:
        return 0
    return int(fields[8]) * _TICK_NS if len(fields) > 8 else 0
