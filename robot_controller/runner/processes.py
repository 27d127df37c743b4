"""Child processes as ``ros2 launch`` runs them: forked (``forking``), placed (``scheduling``), output
prefixed with their name, stopped with SIGINT then SIGKILL, dying with the launcher (``PR_SET_PDEATHSIG``); and what
they cost, CPU time (percent of one core) and resident memory from ``/proc``, sampled once after start-up and once
at the end (:class:`UsageMeter`)."""

from __future__ import annotations

import functools
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from robot_controller.ros import scheduling
from robot_controller.runner import forking

# Over a node's own cleanup limit (ros.process.CLEANUP_TIMEOUT_S, then faulthandler's second).
STOP_TIMEOUT_S = 8.0


# Re-entrant: a signal handler that prints must not deadlock on a print it interrupted.
_print_lock = threading.RLock()


def say(message: str) -> None:
    with _print_lock:
        print(f"[launcher] {message}", flush=True)


def _child_setup(place: scheduling.Placement) -> None:
    """In the child, first thing after the fork."""
    forking.die_with_parent()
    scheduling.apply_in_child(place)


@dataclass(frozen=True)
class Process:
    """How a child starts: ``python -m robot_controller.nodes.<module> <args>`` with ``env``."""

    name: str  #: as the output prefix and in the usage figures
    module: str
    args: list[str]
    env: dict[str, str]


@dataclass
class Child:
    spec: Process
    process: forking.ForkedProcess
    reader: threading.Thread  #: relays its output; started by ``ProcessGroup.relay``

    @property
    def name(self) -> str:
        return self.spec.name


@dataclass
class ProcessGroup:
    """Child processes with prefixed output; a context manager that always stops them."""

    children: list[Child] = field(default_factory=list)

    def start(self, spec: Process, *, on_line: Callable[[str], bool] | None = None, wall_clock: bool = True) -> Child:
        """Fork ``spec``; ``on_line`` sees each output line first and returns True for one it consumed."""
        process = forking.fork(
            spec.module,
            [f"robot_controller.nodes.{spec.module}", *spec.args],
            spec.env,
            functools.partial(_child_setup, scheduling.placement(spec.name, wall_clock)),
        )
        reader = threading.Thread(target=self._relay, args=(spec.name, process, on_line), daemon=True)
        child = Child(spec, process, reader)
        self.children.append(child)
        return child

    @staticmethod
    def _relay(name: str, process: forking.ForkedProcess, on_line: Callable[[str], bool] | None) -> None:
        assert process.stdout is not None
        for line in process.stdout:
            if on_line is not None and on_line(line):
                continue
            with _print_lock:
                sys.stdout.write(f"[{name}] {line}")
                sys.stdout.flush()

    def restart(self, child: Child) -> Child:
        """Start a dead child again, as it was started (``--respawn``)."""
        child.reader.join(timeout=1.0)
        self.children.remove(child)
        again = self.start(child.spec)
        self.relay()
        return again

    def relay(self) -> None:
        """Start relaying every child's output, once all are forked (a fork copies the locks other threads hold)."""
        for child in self.children:
            if not child.reader.is_alive() and child.reader.ident is None:
                child.reader.start()

    def dead(self) -> list[tuple[str, int]]:
        return [(c.name, c.process.returncode) for c in self.children if c.process.poll() is not None]

    def stop(
        self,
        children: list[Child] | None = None,
        timeout_s: float = STOP_TIMEOUT_S,
        reported: dict[str, Callable[[], float]] | None = None,
    ) -> dict[str, int]:
        """SIGINT ``children`` (default all), then SIGKILL any silent ``timeout_s``: not exited, nor, by
        ``reported[name]()`` (when it last reported, monotonic s), still working; each one's exit code."""
        children = self.children if children is None else children
        for child in children:
            if child.process.poll() is None:
                try:
                    os.killpg(child.process.pid, signal.SIGINT)
                except ProcessLookupError:
                    pass
        sent, reported = time.monotonic(), reported or {}
        for child in children:
            last_report = reported.get(child.name, lambda: 0.0)
            while True:
                heard = max(sent, last_report())
                try:
                    child.process.wait(timeout=max(0.0, heard + timeout_s - time.monotonic()))
                    break
                except subprocess.TimeoutExpired:
                    if last_report() <= heard:  # stuck, not slow: silent all along
                        say(f"{child.name} neither exited nor reported for {timeout_s:g} s after SIGINT: killing it")
                        os.killpg(child.process.pid, signal.SIGKILL)
                        child.process.wait()
                        break
        for child in children:
            if child.reader.ident is not None:
                child.reader.join(timeout=1.0)
        return {c.name: c.process.returncode for c in children}

    def __enter__(self) -> ProcessGroup:
        return self

    def __exit__(self, *exc_info) -> None:
        self.stop()


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
