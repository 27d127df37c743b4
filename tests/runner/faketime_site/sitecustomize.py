"""Loaded (through PYTHONPATH) by the processes a test runs under Debian's faketime 0.9.10 with
FAKETIME_DONT_FAKE_MONOTONIC=1: there Python 3.11's time.sleep fails with EINVAL, libfaketime moving its
CLOCK_MONOTONIC TIMER_ABSTIME deadline (wolfcw/libfaketime issue 426). select's timeout is relative: sleep on it."""

import select
import time


def _sleep(seconds: float) -> None:
    if seconds < 0:
        raise ValueError("sleep length must be non-negative")
    select.select([], [], [], seconds)


time.sleep = _sleep
