"""One run of a campaign and where it runs. The run: its draws over the campaign's stack, the in-process loop (the
nodes' core code, no ROS) for the campaign's duration, and its row of figures; a run that raises is a row too, failed
with its reason. Where: local worker processes, or the tasks of a Ray cluster the user started; both take the same
tasks and yield the same rows (each run's figures depend on its task alone), as the runs finish.

Either way a worker runs each run in a child process forked from it (:func:`attempt`): a run stuck in C code that holds
the GIL stalls every thread of its process, so no thread can stop it, but a process can be killed. A run past its
limit is killed (SIGKILL) and recorded as ``timed_out``; one whose process dies (a crash in C) as ``failed``, with the
signal; either is tried once more (:func:`run`). The worker itself never blocks, so the campaign always ends."""

from __future__ import annotations

import logging
import math
import os
import pickle
import select
import signal
import time
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, replace
from typing import Any

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError, RunFailed
from robot_controller.experiments.campaign import identified_world
from robot_controller.experiments.campaign.run_figures import figures
from robot_controller.experiments.campaign.spec import columns, layer
from robot_controller.runner.forking import die_with_parent

#: The row's columns that are the host's, not the run's: left out when two campaigns' figures are compared.
HOST_COLUMNS = ("wall_s", "cpu_s", "attempts", "first_failure")
#: Tries of a run beyond its first, when it fails or times out.
RETRIES = 1
#: Tasks in flight per worker: enough that none waits for the next, few enough that rows stream in order.
IN_FLIGHT_PER_WORKER = 2
#: How often a local worker checks that the campaign that started it is still there, s.
PARENT_POLL_S = 0.25


@dataclass(frozen=True)
class Task:
    """What a worker needs for one run (pickled to a process or a Ray worker)."""

    run_id: int
    controller: str  #: the label of the compared controller ("" for the spec's only one)
    params: cfg.Params  #: the campaign's stack with this controller
    drawn: dict[str, Any]
    seed: int
    duration_s: float
    timeout_s: float = math.inf  #: the run's wall-time limit, s (``executors`` holds it to it)
    identify: bool = False  #: the world identified before the run (:mod:`.identified_world`)
    tune: str = ""  #: and its gains tuned for this target ("": not)


def head(task: Task) -> dict[str, Any]:
    """The columns that name the run: ``run_id``, ``controller``, ``seed`` and every drawn value."""
    row: dict[str, Any] = {"run_id": task.run_id, "controller": task.controller, "seed": task.seed}
    row.update(columns(task.drawn))
    return row


def in_process_row(task: Task) -> dict[str, Any]:
    """Task's row: ``run_id``, ``controller``, ``seed``, every drawn value, every figure, ``status`` and ``reason``."""
    row = head(task)
    start, cpu_start = time.perf_counter(), time.process_time()
    try:
        params = run_params(task.params, task.drawn, task.seed)
        if task.identify:
            params = identified_world.prepared(params, task.seed, task.tune, row)
        row.update(figures(params, task.duration_s, task.seed))
    except Exception as exc:  # noqa: BLE001 - a world the stack refuses or a loop that breaks: a row, not a crash
        row.update(status="failed", reason=" ".join(f"{type(exc).__name__}: {exc}".split())[:300])
    row["wall_s"] = time.perf_counter() - start
    row["cpu_s"] = time.process_time() - cpu_start  # beside wall_s: how much of the core the host gave the run
    return row


def run_params(params: cfg.Params, drawn: dict[str, Any], seed: int) -> cfg.Params:
    """The stack of one run: the draws over the campaign's stack, each value checked by its schema, the seed."""
    drawn_layer = layer(drawn)
    for node, values in drawn_layer.items():
        for name, value in values.items():
            values[name] = cfg.spec_of(node, name).validate(value)
    return cfg.merge(params, drawn_layer, {"sensor_node": {"seed": seed}})


#: s of simulated time of the run a worker makes once, in itself, before its first forked run (past the scoring's
#: own 2 s start, so the figures are computed too)
WARM_UP_S = 2.5
#: wall s the warm-up may take; past it, it is abandoned (it runs unguarded by a fork)
WARM_UP_TIMEOUT_S = 30.0
_warmed = False


class _WarmUpTimedOut(Exception):
    pass


def warm_up(task: Task) -> None:
    """Once per worker process: a short run of the campaign's stack, undrawn, in the worker itself, so every run it
    forks inherits what a first run loads (modules imported on first use, caches filled): a forked Panda run went
    from 0.65 to 0.46 CPU s. A warm-up that fails or overruns is abandoned: each run still says its own."""
    global _warmed
    if _warmed:
        return
    _warmed = True

    def overrun(*_: object) -> None:
        raise _WarmUpTimedOut

    previous = signal.signal(signal.SIGALRM, overrun)
    signal.setitimer(signal.ITIMER_REAL, min(WARM_UP_TIMEOUT_S, task.timeout_s))
    try:
        figures(run_params(task.params, {}, task.seed), WARM_UP_S, task.seed)
    except Exception:  # noqa: BLE001, S110 - abandoned: the runs are what count, and each says what went wrong
        pass
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def run(task: Task) -> dict[str, Any]:
    """Task's row, its run held to ``task.timeout_s`` of wall time and tried again once if it failed; ``attempts``
    says how many tries it took, ``first_failure`` why the first failed (empty when it did not)."""
    warm_up(task)
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
            die_with_parent(signal.SIGKILL, os.getppid())  # a killed campaign leaves no run behind
            data = pickle.dumps(in_process_row(task))
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
    row = head(task)
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


def _exit_said(status: int) -> str:
    if os.WIFSIGNALED(status):
        number = os.WTERMSIG(status)
        try:
            return f"signal {number}, {signal.Signals(number).name}"
        except ValueError:
            return f"signal {number}"
    return f"exit code {os.waitstatus_to_exitcode(status)}"


def default_workers() -> int:
    return os.cpu_count() or 1


def run_local(tasks: Iterable[Task], workers: int) -> Iterator[dict[str, Any]]:
    """``tasks`` on ``workers`` processes, forked from this one (the stack already imported), each exiting with it."""
    import multiprocessing
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    todo = iter(tasks)
    context = multiprocessing.get_context("fork")
    with ProcessPoolExecutor(workers, mp_context=context, initializer=_exit_with_parent) as pool:
        pending = set()
        try:
            while True:
                while len(pending) < IN_FLIGHT_PER_WORKER * workers and (task := next(todo, None)) is not None:
                    pending.add(pool.submit(run, task))
                if not pending:
                    return
                finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in finished:
                    yield future.result()
        finally:
            for future in pending:
                future.cancel()


def _exit_with_parent() -> None:
    """In a worker: exit once the campaign that forked it has gone (killed with SIGKILL, say): a pool's workers
    hold their own task queue open and would otherwise wait on it for ever."""
    import threading

    parent = os.getppid()

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        os._exit(1)

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


def _run_remote(params, task: Task) -> dict[str, Any]:
    """A Ray task: the campaign's stack arrives once per worker as an object, the task without it."""
    return run(replace(task, params=params))


def connect_ray(address: str) -> int:
    """Connect to the Ray cluster at ``address`` (``auto``: ``RAY_ADDRESS``, or the one on this host); its CPUs.

    :raises RunFailed: no cluster answers there
    """
    try:
        import ray
    except ImportError:
        raise ConfigError("--ray: the ray package is not installed (pip install ray)") from None
    host, _, port = address.rpartition(":")
    if address != "auto" and port.isdigit() and not _listening(host or "127.0.0.1", int(port)):
        # ray.init retries an address where nothing listens for a minute or more: say so at once
        raise RunFailed(
            f"--ray {address}: no Ray cluster to connect to (nothing listens there); start one with "
            "`ray start --head`"
        )
    try:
        ray.init(address=address, logging_level=logging.ERROR, log_to_driver=False, configure_logging=False)
    except (ConnectionError, RuntimeError, ValueError) as exc:
        said = " ".join(str(exc).split())[:200]
        raise RunFailed(
            f"--ray {address}: no Ray cluster to connect to ({said}); start one with `ray start --head`"
        ) from None
    return max(1, int(ray.cluster_resources().get("CPU", 1)))


def _listening(host: str, port: int) -> bool:
    import socket

    try:
        with socket.create_connection((host, port), timeout=5):
            return True
    except OSError:
        return False


def run_ray(tasks: Iterable[Task], address: str) -> Iterator[dict[str, Any]]:
    """``tasks`` as Ray tasks on the cluster at ``address``, one CPU each."""
    import ray

    cpus = connect_ray(address)
    try:
        yield from ray_rows(tasks, cpus)
    finally:
        ray.shutdown()


def ray_rows(tasks: Iterable[Task], cpus: int) -> Iterator[dict[str, Any]]:
    """``tasks`` on the Ray cluster this process is connected to (``cpus`` of them), rows as they finish."""
    import ray

    remote = ray.remote(num_cpus=1, max_retries=0)(_run_remote)
    todo = iter(tasks)
    params_refs: dict[int, Any] = {}  # one object per distinct stack (one per compared controller)
    pending: list = []
    while True:
        while len(pending) < IN_FLIGHT_PER_WORKER * cpus and (task := next(todo, None)) is not None:
            ref = params_refs.get(id(task.params))
            if ref is None:
                ref = params_refs[id(task.params)] = ray.put(task.params)
            pending.append(remote.remote(ref, replace(task, params=None)))
        if not pending:
            return
        finished, pending = ray.wait(pending, num_returns=1)
        for ref in finished:
            yield ray.get(ref)
