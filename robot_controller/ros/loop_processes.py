"""Where the loop's processes spent a stretch of wall time: running, or kept from running by the host.

Each stack node leaves its pid in the run's scratch folder (``COUNTS_DIR_ENV``). Over a late effort's wait (the
paced world) or a missed cycle (the controller, on the wall clock) this reads the loop's threads' run-queue wait
(``schedstat``), the hypervisor's steal and the CPU time everything else used (``/proc/stat`` less the loop's). A
wait the host filled is the host's, not the loop's own miss; processes of the loop that keep each other waiting
overload their own cores, the loop's fault. Linux only; elsewhere every miss is the loop's."""

from __future__ import annotations

import os
import threading
import time
from dataclasses import dataclass
from pathlib import Path

from robot_controller.ros.publishing import leave

PID_FILE_PREFIX = "pid."
REFIND_S = 1.0  #: how often the loop's threads are listed again, s
_TICK_NS = 1_000_000_000 // (os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100)
_CPUS = os.cpu_count() or 1


def leave_pid(node_name: str) -> None:
    leave(f"{PID_FILE_PREFIX}{node_name}", str(os.getpid()))


@dataclass(frozen=True)
class Usage:
    """Over a stretch of time, ns."""

    cpu_ns: int
    run_wait_ns: int
    steal_ns: int
    others_ns: int = 0


@dataclass(frozen=True)
class Sample:
    """At one instant, ns: each watched thread's (pid, CPU time, run-queue wait) by thread id, the host's steal over
    all its CPUs, the CPU time of everything but the loop's processes (counters: only differences mean anything)."""

    threads: dict[int, tuple[int, int, int]]
    steal_ns: int
    others_ns: int = 0

    def __sub__(self, earlier: Sample) -> Usage:
        """What happened since ``earlier``, over the threads both saw: each process waits as long as its
        longest-waiting thread (they wait side by side); the steal a CPU's share and the others' CPU time, each less
        one step of its counter (what it certainly was)."""
        cpu_ns, wait_by_pid = 0, {}
        for tid in self.threads.keys() & earlier.threads.keys():
            pid, cpu_now, wait_now = self.threads[tid]
            _, cpu_then, wait_then = earlier.threads[tid]
            cpu_ns += cpu_now - cpu_then
            wait_by_pid[pid] = max(wait_by_pid.get(pid, 0), wait_now - wait_then)
        steal_ns = max(0, self.steal_ns - earlier.steal_ns - _TICK_NS) // _CPUS
        others_ns = max(0, self.others_ns - earlier.others_ns - _TICK_NS)
        return Usage(cpu_ns, sum(wait_by_pid.values()), steal_ns, others_ns)


def thread_run_wait_s() -> float:
    """How long the calling thread has waited for a CPU since it started, s; 0 where unreadable: nothing excused."""
    try:
        with open("/proc/thread-self/schedstat", "rb") as f:
            return int(f.read().split()[1]) * 1e-9
    except (OSError, IndexError, ValueError):
        return 0.0


def process_run_wait_s() -> float:
    """The calling thread's and the main thread's (the executor's, which may hold the interpreter's lock the calling
    thread waits for) waits for a CPU, s, summed."""
    try:
        with open("/proc/self/schedstat", "rb") as f:  # the thread group's leader: the main thread
            main_s = int(f.read().split()[1]) * 1e-9
    except (OSError, IndexError, ValueError):
        main_s = 0.0
    return main_s + (thread_run_wait_s() if threading.get_native_id() != os.getpid() else 0.0)


def thread_kept_s() -> float:
    """How long the host has kept the calling thread from running, s: its run-queue wait and a CPU's share of the
    hypervisor's steal since boot."""
    try:
        with open("/proc/stat", "rb") as f:
            steal_ticks = int(f.readline().split()[8])
    except (OSError, IndexError, ValueError):
        steal_ticks = 0
    return thread_run_wait_s() + steal_ticks * _TICK_NS * 1e-9 / _CPUS


def host_kept_waiting(used: Usage, late_ns: int) -> bool:
    """Whether the host took at least ``late_ns`` from the loop over ``used``: the steal, and the loop's wait for a
    CPU as far as other programs used the CPUs meanwhile."""
    return min(used.run_wait_ns, used.others_ns) + used.steal_ns >= late_ns


def _watched(comm: str) -> bool:
    """A thread on the loop's path: Python's (the executor, a pacing thread) and Fast DDS's receivers."""
    return not comm.startswith("dds.") or (comm.startswith(("dds.shm.", "dds.udp.")) and comm != "dds.shm.wdog")


class LoopProcesses:
    """The loop's processes as found in ``counts_dir`` and their threads on the loop's path, each read through a
    file kept open (a few microseconds a read)."""

    def __init__(self, counts_dir: str) -> None:
        self.counts_dir = Path(counts_dir) if counts_dir else None
        self.files: dict[int, tuple[int, int]] = {}  #: tid → (pid, its open schedstat file)
        self.passed_over: set[int] = set()  #: tids not on the loop's path (DDS's other threads)
        self.found_at = -float("inf")  #: when (monotonic s) the threads were last listed
        self.stat_file: int | None = None
        self.process_files: dict[int, int] = {}  #: pid → its open /proc/<pid>/stat

    def _find(self) -> None:
        """List the threads again (once a second: threads start late, a respawned node has a new pid)."""
        self.found_at = time.monotonic()
        if self.counts_dir is None:
            return
        for path in self.counts_dir.glob(f"{PID_FILE_PREFIX}*"):
            try:
                pid = int(path.read_text())
                tids = [int(tid) for tid in os.listdir(f"/proc/{pid}/task")]
            except (OSError, ValueError):
                continue  # ended, or half written
            if pid not in self.process_files:
                try:
                    self.process_files[pid] = os.open(f"/proc/{pid}/stat", os.O_RDONLY)
                except OSError:
                    continue
            for tid in tids:
                if tid in self.files or tid in self.passed_over:
                    continue
                try:
                    with open(f"/proc/{pid}/task/{tid}/comm") as f:
                        if not _watched(f.read().strip()):
                            self.passed_over.add(tid)
                            continue
                    self.files[tid] = (pid, os.open(f"/proc/{pid}/task/{tid}/schedstat", os.O_RDONLY))
                except OSError:
                    continue

    def usage(self) -> Sample | None:
        if time.monotonic() - self.found_at > REFIND_S:
            self._find()
        threads = {}
        for tid, (pid, fd) in list(self.files.items()):
            try:
                fields = os.pread(fd, 128, 0).split()
            except OSError:  # the thread ended
                self.files.pop(tid)
                os.close(fd)
                continue
            threads[tid] = (pid, int(fields[0]), int(fields[1]))
        if not threads:
            return None
        busy_ns, steal_ns = self._host_ns()
        return Sample(threads, steal_ns, busy_ns - self._loop_cpu_ns())

    def any_stopped(self) -> bool:
        """Whether a process of the loop is stopped now (SIGSTOP, a debugger): frozen alone, not with the host."""
        for fd in list(self.process_files.values()):
            try:
                if os.pread(fd, 1024, 0).rsplit(b")", 1)[1].split()[0] in (b"T", b"t"):
                    return True
            except (OSError, IndexError):
                continue
        return False

    def close(self) -> None:
        for fd in [fd for _, fd in self.files.values()] + list(self.process_files.values()):
            os.close(fd)
        self.files.clear()
        self.process_files.clear()
        if self.stat_file is not None:
            os.close(self.stat_file)
            self.stat_file = None

    def _host_ns(self) -> tuple[int, int]:
        """Every CPU's busy time (user, nice, system, irq, softirq) and the steal since boot, ns."""
        try:
            if self.stat_file is None:
                self.stat_file = os.open("/proc/stat", os.O_RDONLY)
            fields = [int(f) for f in os.pread(self.stat_file, 256, 0).split(b"\n", 1)[0].split()[1:]]
        except (OSError, ValueError):
            return 0, 0
        if len(fields) < 8:
            return 0, 0
        return (fields[0] + fields[1] + fields[2] + fields[5] + fields[6]) * _TICK_NS, fields[7] * _TICK_NS

    def _loop_cpu_ns(self) -> int:
        """The CPU time the loop's processes have used, ns (utime and stime)."""
        total = 0
        for pid, fd in list(self.process_files.items()):
            try:
                fields = os.pread(fd, 1024, 0).rsplit(b")", 1)[1].split()
                total += (int(fields[11]) + int(fields[12])) * _TICK_NS
            except (OSError, IndexError, ValueError):  # it ended
                os.close(self.process_files.pop(pid))
        return total
