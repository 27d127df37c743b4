"""Each campaign run held to its wall-time limit, and tried once more if it fails. The run runs in a child process
forked from the worker (a local pool's or Ray's): a run stuck in C code that holds the GIL stalls every thread of its
process, so no thread can stop it, but a process can be killed. A run past its limit is killed (SIGKILL) and recorded
as ``timed_out``; one whose process dies (a crash in C) as ``failed``, with the signal. The worker itself never
blocks, so the campaign always ends."""

from __future__ import annotations

import os
import pickle
import select
import signal
import time
from typing import Any

from robot_controller.experiments.campaign import one_run
from robot_controller.experiments.campaign.one_run import Task
from robot_controller.runner.forking import die_with_parent

#: Tries of a run beyond its first, when it fails or times out.
RETRIES = 1


def run(task: Task) -> dict[str, Any]:
    """Task's row, its run held to ``task.timeout_s`` of wall time and tried again once if it failed; ``attempts``
    says how many tries it took, ``first_failure`` why the first failed (empty when it did not)."""
    row = attempt(task)
    first_failure = ""
    for tries in range(2, RETRIES + 2):
        if row["status"] == "ok":
            break
        first_failure = first_failure or row["reason"]
        row = attempt(task)
        row["attempts"] = tries
    row.setdefault("attempts", 1)
    row["first_failure"] = first_failure
    return row


def attempt(task: Task) -> dict[str, Any]:
    """One try of the run in a forked child: its row, or ``timed_out`` once past ``task.timeout_s`` (the child
    killed), or ``failed`` when the child died without a row."""
    read_fd, write_fd = os.pipe()
    start = time.monotonic()
    pid = os.fork()
    if pid == 0:  # the child: the run, its row down the pipe, then out without the parent's exit handlers
        code = 1
        try:
            os.close(read_fd)
            _die_with(os.getppid())
            data = pickle.dumps(one_run.run(task))
            with os.fdopen(write_fd, "wb") as pipe:
                pipe.write(data)
            code = 0
        finally:
            os._exit(code)
    os.close(write_fd)
    data, finished = _read(read_fd, start + task.timeout_s)
    if not finished:
        os.kill(pid, signal.SIGKILL)
    _, status = os.waitpid(pid, 0)
    wall_s = time.monotonic() - start
    if finished and data:
        return pickle.loads(data)
    row = one_run.head(task)
    if not finished:
        why = f"timed out: still running after {task.timeout_s:g} s of wall time (run_timeout_s); its process killed"
        row.update(status="timed_out", reason=why)
    else:
        row.update(status="failed", reason=f"its process died ({_exit_said(status)}) without a row")
    row.update(wall_s=wall_s, cpu_s=float("nan"))
    return row


def _read(fd: int, deadline: float) -> tuple[bytes, bool]:
    """What comes down the pipe until it closes (True) or ``deadline`` on the monotonic clock passes (False)."""
    chunks = []
    try:
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return b"".join(chunks), False
            ready, _, _ = select.select([fd], [], [], left)
            if not ready:
                continue
            chunk = os.read(fd, 1 << 16)
            if not chunk:
                return b"".join(chunks), True
            chunks.append(chunk)
    finally:
        os.close(fd)


def _die_with(parent: int) -> None:
    """In the child: be killed when the worker that forked it ends (a killed campaign leaves no run behind, even one
    stuck in C code)."""
    die_with_parent(signal.SIGKILL, parent)


def _exit_said(status: int) -> str:
    if os.WIFSIGNALED(status):
        number = os.WTERMSIG(status)
        try:
            return f"signal {number}, {signal.Signals(number).name}"
        except ValueError:
            return f"signal {number}"
    return f"exit code {os.waitstatus_to_exitcode(status)}"
