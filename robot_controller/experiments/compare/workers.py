"""``compare``'s (contender, seed) pairs side by side in spawned workers, each on a ROS domain of its
own; Ctrl-C or the caller's death ends each worker's run cleanly."""

from __future__ import annotations

import multiprocessing
import os
import signal
from concurrent import futures
from pathlib import Path

from robot_controller.experiments.compare.contenders import Contender
from robot_controller.experiments.compare.pairs import run_pair


def worker_domain(base: int, slot: int) -> int:
    """The ROS domain of worker ``slot``: the caller's (``base``) for slot 0, the next ones after, within 1..101."""
    return (base - 1 + slot) % 101 + 1


def run_side_by_side(
    pairs, out: Path, sine_duration_s: float, amplitude: float, progress, workers: int
) -> dict[tuple[str, int], dict[str, float]]:
    """Run the pairs on ``workers`` spawned processes (the launcher forks the nodes, so its process must be
    single-threaded), never more at once than workers: each progress line is printed as its pair starts."""
    context = multiprocessing.get_context("spawn")
    slots = context.Value("i", 0)
    try:
        base = int(os.environ.get("ROS_DOMAIN_ID", "0"))
    except ValueError:
        base = 0
    figures: dict[tuple[str, int], dict[str, float]] = {}
    todo = iter(pairs)
    running: dict[futures.Future, tuple[str, int]] = {}
    pool = futures.ProcessPoolExecutor(
        max_workers=min(workers, len(pairs)) or 1, mp_context=context, initializer=_init_worker, initargs=(slots, base)
    )
    try:

        def start_next() -> None:
            for contender, seed in todo:
                progress(f"{contender.name}: seed {seed}")
                future = pool.submit(_compare_pair_in_worker, contender, seed, out, sine_duration_s, amplitude)
                running[future] = (contender.name, seed)
                return

        for _ in range(workers):
            start_next()
        while running:
            done, _ = futures.wait(running, return_when=futures.FIRST_COMPLETED)
            for future in done:
                key = running.pop(future)
                figures[key] = future.result()  # a failed run raises here: RuntimeError naming its directory
                start_next()
    finally:
        # On a failure (or Ctrl-C) the pairs under way end first, their nodes stopped cleanly.
        pool.shutdown(wait=True, cancel_futures=True)
    return figures


# In a worker process: its ROS domain, and whether Ctrl-C arrived during a task.
_domain_id: int | None = None
_interrupted = False
_parent_pid: int | None = None


def _init_worker(slots, base: int) -> None:
    global _domain_id, _parent_pid
    with slots.get_lock():
        slot = slots.value
        slots.value += 1
    _domain_id = worker_domain(base, slot)
    _parent_pid = os.getppid()
    # Ctrl-C reaches the whole process group: idle workers leave it to the caller.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # If the caller dies, SIGTERM: the launcher stops the current run's nodes as for Ctrl-C.
    from robot_controller.runner import forking

    forking.die_with_parent()


def _on_sigint(signum, frame) -> None:
    global _interrupted
    _interrupted = True
    raise KeyboardInterrupt


def stop_if_asked() -> None:
    """In a worker, after a run the launcher ended on Ctrl-C or SIGTERM: go on to no next run."""
    if _interrupted or (_parent_pid is not None and os.getppid() != _parent_pid):
        raise KeyboardInterrupt


def _compare_pair_in_worker(
    contender: Contender, seed: int, out: Path, sine_duration_s: float, amplitude: float
) -> dict[str, float]:
    global _interrupted
    _interrupted = False
    signal.signal(signal.SIGINT, _on_sigint)
    try:
        return run_pair(
            contender, seed, out, sine_duration_s, amplitude, domain_id=_domain_id, between_runs=stop_if_asked
        )
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
