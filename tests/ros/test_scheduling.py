"""A helper process forked from a loop node (the law designer) gives the loop its CPU and its priority."""

import multiprocessing
import os

import pytest

from robot_controller.ros import scheduling


def _pinned_then_yielded(loop_cpu: int, said: multiprocessing.Queue) -> None:
    os.sched_setaffinity(0, {loop_cpu})  # as a wall-clock loop node is pinned
    scheduling.yield_to_the_loop()
    said.put((os.getpriority(os.PRIO_PROCESS, 0), sorted(os.sched_getaffinity(0))))


@pytest.mark.skipif(len(os.sched_getaffinity(0)) < 2, reason="one CPU allowed: nowhere else to go")
def test_a_helper_forked_from_a_pinned_loop_node_leaves_the_loops_cpu_and_priority():
    loop_cpu = max(os.sched_getaffinity(0))
    context = multiprocessing.get_context("fork")
    said = context.Queue()
    child = context.Process(target=_pinned_then_yielded, args=(loop_cpu, said))
    child.start()
    nice, cpus = said.get(timeout=30)
    child.join(timeout=30)
    assert nice == 19
    assert cpus and loop_cpu not in cpus
