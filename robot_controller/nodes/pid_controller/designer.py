"""The law of a parameter change designed and checked in a process of its own (:class:`Designer`): finding a
design's delay margin is small numpy steps for tens of ms per joint, and in the node's process those hold the
interpreter against the loop's thread, which needs it back at every message it takes or publishes (a refused
``lqr_r`` checked on a thread of the node still stalled its loop 0.3 s, and the drive braked)."""

from __future__ import annotations

import multiprocessing
import os
import signal
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import TYPE_CHECKING

from robot_controller.blocks.controller import designed_margin
from robot_controller.core.errors import ConfigError
from robot_controller.runner.forking import die_with_parent

if TYPE_CHECKING:
    from robot_controller.core.controller import ControllerConfig
    from robot_controller.core.model import ArmDynamics

_dynamics: ArmDynamics | None = None  # the worker's arm model: the design's copy, as it was when the node forked it


def _start_worker(dynamics: ArmDynamics | None, node_pid: int) -> None:
    global _dynamics
    _dynamics = dynamics
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a Ctrl-C is the node's to act on; the worker ends with it
    # A node killed (SIGKILL, the launcher's last resort) never shuts the pool down: the worker would wait on its
    # call queue for ever, an orphan (44 of them were seen on a busy host).
    die_with_parent(signal.SIGKILL, node_pid)


def _check(config: ControllerConfig, joint_count: int) -> tuple[int | None, str | None]:
    """In the worker: ``(margin, None)``, or ``(None, the reason)`` for a refused design."""
    try:
        return designed_margin(config, _dynamics, joint_count), None
    except ConfigError as exc:
        return None, str(exc)


class Designer:
    """:func:`designed_margin` on ``dynamics`` (a copy the loop never touches) in one worker process, forked when
    the designer is made: it starts with everything imported and the model built."""

    def __init__(self, dynamics: ArmDynamics | None, joint_count: int) -> None:
        self._dynamics, self._joint_count = dynamics, joint_count
        context = multiprocessing.get_context("fork")
        self._pool = ProcessPoolExecutor(1, context, initializer=_start_worker, initargs=(dynamics, os.getpid()))
        self._pool.submit(int)  # the fork now, at the start, not at the first change

    def margin(self, config: ControllerConfig) -> int | None:
        """:func:`designed_margin` of ``config``, waited for (the caller's thread lets go of the interpreter)."""
        try:
            margin, refused = self._pool.submit(_check, config, self._joint_count).result()
        except BrokenProcessPool:  # the worker is gone (killed): designed here, as correct, if slower for the loop
            return designed_margin(config, self._dynamics, self._joint_count)
        if refused is not None:
            raise ConfigError(refused)
        return margin

    def stop(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)
