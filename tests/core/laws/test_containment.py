"""A contained law that blocks or ends the process: the controller stops waiting for a call still
running a control period past its budget, contains SystemExit and KeyboardInterrupt as any
exception, dates a failure by the tick it happened on, and does not count against a law the time
the host kept it from a CPU. Small budgets; behaviour, not timings."""

from __future__ import annotations

import gc
import threading
import time

import numpy as np
import pytest

from robot_controller.core.laws import Arm
from robot_controller.core.laws.collection_time import collected_s
from robot_controller.core.laws.containment import ContainedLaw

ARM = Arm(None, ("joint 1",), np.array([np.inf]), np.array([[-np.inf, np.inf]]))


class Blocking:
    """Blocks in its second update until ``release`` is set (a deadlock, or a long sleep)."""

    def __init__(self) -> None:
        self.calls = 0
        self.release = threading.Event()
        self.went_on = False  # set only if the abandoned call ran past its block

    def update(self, time_s, state, reference):
        self.calls += 1
        if self.calls == 2:
            self.release.wait()
            self.went_on = True
        return np.ones(1)


def contained(law, clock=time.perf_counter, budget_s=0.001, period_s=0.005, run_wait=None) -> ContainedLaw:
    return ContainedLaw(law, type(law).__name__, ARM, period_s, {}, clock=clock, budget_s=budget_s, run_wait=run_wait)


def test_a_law_that_blocks_is_abandoned_on_that_tick_and_never_called_again():
    law = Blocking()
    held = contained(law)
    assert held.update(1.0, None, None).tolist() == [1.0] and held.fault is None
    assert held.update(1.005, None, None).tolist() == [0.0]  # the controller went on without it
    assert law.calls == 2 and not law.went_on
    line = held.fault.line()
    assert "Blocking was still in update()" in line and "over its budget of 1 ms (law_budget_s)" in line, line
    assert line.endswith("abandoned at t = 1.005 s"), line
    assert held.update(1.01, None, None).tolist() == [0.0] and law.calls == 2  # never called again
    # Released, the abandoned call is asked to end at its next instruction: it never goes on.
    law.release.set()
    held.worker._thread.join(timeout=10.0)
    assert not held.worker._thread.is_alive() and not law.went_on


def test_a_law_that_sleeps_far_past_its_budget_once_is_a_fault():
    class SleepsOnce:
        def __init__(self) -> None:
            self.calls = 0

        def update(self, time_s, state, reference):
            self.calls += 1
            if self.calls == 3:
                time.sleep(2.0)
            return np.zeros(1)

    held = contained(SleepsOnce())
    for t in (0.0, 0.005, 0.01):
        held.update(t, None, None)
    assert "over its budget of 1 ms (law_budget_s) by more than a control period" in held.fault.line()
    assert held.fault.time_s == 0.01


def test_a_lone_modest_overrun_is_not_a_fault():
    class SlowOnce:
        def __init__(self) -> None:
            self.calls = 0

        def update(self, time_s, state, reference):
            self.calls += 1
            if self.calls == 2:
                time.sleep(0.01)  # ten times its budget, far less than the period past it
            return np.zeros(1)

    held = contained(SlowOnce(), budget_s=0.001, period_s=2.0)
    for t in (0.0, 2.0, 4.0):
        held.update(t, None, None)
    assert held.fault is None


class Preempted:
    """Each update takes 3 ms on its clock, 2.5 ms of them waiting for a CPU (a busy host): 0.5 ms its own."""

    def __init__(self) -> None:
        self.now_s, self.waited_s = 0.0, 0.0

    def update(self, time_s, state, reference):
        self.now_s += 0.003
        self.waited_s += 0.0025
        return np.zeros(1)


def test_the_time_the_host_kept_a_law_from_a_cpu_is_not_the_laws():
    law = Preempted()
    held = contained(law, clock=lambda: law.now_s, run_wait=lambda: law.waited_s, period_s=1.0)
    for t in range(5):
        held.update(float(t), None, None)
    assert held.fault is None
    # Without knowing what the host took, the same law is over its 1 ms budget three ticks running.
    law = Preempted()
    held = contained(law, clock=lambda: law.now_s, period_s=1.0)
    for t in range(3):
        held.update(float(t), None, None)
    assert "took 3.0, 3.0, 3.0 ms in update() on 3 ticks running" in held.fault.line()


@pytest.mark.parametrize("raised", [SystemExit(3), KeyboardInterrupt()])
@pytest.mark.parametrize("clock", [None, time.perf_counter], ids=["inline", "worker"])
def test_system_exit_and_keyboard_interrupt_from_a_law_are_its_faults(raised, clock):
    class Ends:
        def update(self, time_s, state, reference):
            raise raised

    held = contained(Ends(), clock=clock, period_s=1.0)  # a busy host: no abandonment first
    assert held.update(2.0, None, None).tolist() == [0.0]
    said = f"raised {type(raised).__name__}" + (": 3" if isinstance(raised, SystemExit) else "")
    assert held.fault.line() == f"control law Ends {said} at t = 2.000 s"
    assert type(raised).__name__ in held.fault.traceback


@pytest.mark.parametrize("clock", [None, time.perf_counter], ids=["inline", "worker"])
def test_failures_in_reset_and_set_params_carry_their_ticks_time(clock):
    class FailsAside:
        def update(self, time_s, state, reference):
            return np.zeros(1)

        def reset(self, state):
            raise RuntimeError("no reset")

        def set_params(self, params):
            raise ValueError("no such gain")

    held = contained(FailsAside(), clock=clock, period_s=1.0)
    held.update(2.5, None, None)
    held.set_params({})
    assert held.fault.line().endswith("raised ValueError: no such gain in set_params() at t = 2.500 s")
    before = contained(FailsAside(), clock=clock, period_s=1.0)
    before.set_params({})
    assert before.fault.line().endswith("in set_params() before the first tick")
    at_reset = contained(FailsAside(), clock=clock, period_s=1.0)
    at_reset.reset(None, 3.25)
    assert at_reset.fault.line().endswith("raised RuntimeError: no reset in reset() at t = 3.250 s")


# --- where the world waits for the law (lockstep, the paced world): its budget on its thread's CPU time ---


def world_waits(law, abandon_s: float) -> ContainedLaw:
    held = contained(law, clock=time.thread_time, budget_s=0.001, period_s=0.005)
    held.abandon_s = abandon_s
    return held


class Computes:
    """Uses ``cpu_s`` of its thread's CPU time per update, or loops until ``release`` is set (``cpu_s`` None)."""

    def __init__(self, cpu_s: float | None) -> None:
        self.cpu_s, self.release = cpu_s, threading.Event()

    def update(self, time_s, state, reference):
        until_s = time.thread_time() + (self.cpu_s if self.cpu_s is not None else float("inf"))
        while time.thread_time() < until_s and not self.release.is_set():
            pass
        return np.zeros(1)


def test_where_the_world_waits_a_law_off_a_cpu_for_longer_than_a_period_is_neither_slow_nor_abandoned():
    class Waits:
        """30 ms a call without a CPU: a host that keeps its thread waiting uses none of its time either."""

        def update(self, time_s, state, reference):
            time.sleep(0.03)
            return np.ones(1)

    held = world_waits(Waits(), abandon_s=0.5)
    for t in (0.0, 0.005, 0.01, 0.015):
        assert held.update(t, None, None).tolist() == [1.0]
    assert held.fault is None  # on wall time: 6 control periods past its 1 ms budget, abandoned on the first


def test_where_the_world_waits_a_law_that_blocks_is_still_abandoned():
    law = Blocking()
    held = world_waits(law, abandon_s=0.2)
    held.update(1.0, None, None)
    assert held.update(1.005, None, None).tolist() == [0.0] and not law.went_on
    line = held.fault.line()
    assert "Blocking was still in update() after " in line and "over its budget of 1 ms (law_budget_s)" in line, line
    assert "after 200.0 ms, over" in line and line.endswith("abandoned at t = 1.005 s"), line  # on wall time
    law.release.set()


def test_where_the_world_waits_a_law_that_loops_is_abandoned_on_its_cpu_time_long_before_the_wall_limit():
    law = Computes(None)
    held = world_waits(law, abandon_s=600.0)  # never reached: the test would hang
    assert held.update(0.0, None, None).tolist() == [0.0]
    assert "Computes was still in update()" in held.fault.line() and "ms of CPU time" in held.fault.line()
    law.release.set()


def test_where_the_world_waits_a_law_that_computes_past_its_budget_three_ticks_running_is_slow():
    held = world_waits(Computes(0.002), abandon_s=0.5)
    for t in (0.0, 0.005, 0.01):
        held.update(t, None, None)
    assert "ms in update() on 3 ticks running, over its budget of 1 ms (law_budget_s)" in held.fault.line()


def test_where_the_world_waits_the_interpreters_garbage_collection_is_not_the_laws_time():
    """A full collection due while the law allocates runs on the law's thread; over a large process it takes far more
    than the law's budget (0.2 s, as seen in CI), and it is the interpreter's, not the law's."""
    heap = [[k] for k in range(1_500_000)]  # (a large process: a full collection takes tens of ms or more)

    class CollectedOn:
        def update(self, time_s, state, reference):
            gc.collect()  # (a collection that comes due during the call)
            return np.ones(1)

    held = world_waits(CollectedOn(), abandon_s=0.5)
    started_s = collected_s()
    gc.collect()
    assert collected_s() > started_s  # (this thread's own collection, counted)
    for t in (0.0, 0.005, 0.01, 0.015):
        assert held.update(t, None, None).tolist() == [1.0]
    assert held.fault is None
    del heap
