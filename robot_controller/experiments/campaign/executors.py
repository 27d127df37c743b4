"""Where a campaign's runs run: local worker processes, or the tasks of a Ray cluster the user started. Both take
the same tasks and yield the same rows (each run's figures depend on its task alone), as the runs finish. Either way
a worker runs each run in a child process held to the run's wall-time limit (:mod:`.limits`), so no run can hang it."""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Iterable, Iterator
from dataclasses import replace
from typing import Any

from robot_controller.core.errors import ConfigError, RunFailed
from robot_controller.experiments.campaign import limits
from robot_controller.experiments.campaign.one_run import Task

#: Tasks in flight per worker: enough that none waits for the next, few enough that rows stream in order.
IN_FLIGHT_PER_WORKER = 2
#: How often a local worker checks that the campaign that started it is still there, s.
PARENT_POLL_S = 0.25


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
                    pending.add(pool.submit(limits.run, task))
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
    return limits.run(replace(task, params=params))


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
