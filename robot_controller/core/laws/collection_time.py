"""The CPU time each thread has spent in the interpreter's garbage collection (:func:`collected_s`), which a law's
budget leaves out: a collection runs on whichever thread allocates when it is due, and a full one over a large
process (a test session's, a node's after hours) takes a law's thread 0.2 s of CPU that is not the law's (a 5 ms law
abandoned for it, in CI). Counted through ``gc.callbacks``, from this module's import on."""

from __future__ import annotations

import gc
import threading
import time
from collections import defaultdict
from typing import Any

_started_s: dict[int, float] = {}  #: per thread, its CPU time when the collection running on it began
_collected_s: defaultdict[int, float] = defaultdict(float)  #: per thread, s of CPU time in collections


def collected_s(thread_ident: int | None = None) -> float:
    """s of CPU time the thread (``threading.get_ident()``'s; None: this one) has spent collecting garbage."""
    return _collected_s.get(threading.get_ident() if thread_ident is None else thread_ident, 0.0)


def _count(phase: str, _: dict[str, Any]) -> None:
    ident = threading.get_ident()
    if phase == "start":
        _started_s[ident] = time.thread_time()
    elif (started_s := _started_s.pop(ident, None)) is not None:
        _collected_s[ident] += time.thread_time() - started_s


if _count not in gc.callbacks:
    gc.callbacks.append(_count)
