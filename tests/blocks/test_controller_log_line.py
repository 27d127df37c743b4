"""The tutorial's log line (no ROS graph): once per logging period, at an instant that walks through the period, so
a lockstep run of the 0.5 Hz sine shows the arm across its range (once at the same instant of every second, each
line landed on the sine's zero crossing)."""

import numpy as np
import pytest

from robot_controller.blocks.controller_log_line import LATEST_PHASE, PHASE_STEP, LogSchedule, line, phase_in_period

TICK_S = 0.01


def said(ticks_s, period_s=1.0):
    schedule = LogSchedule(period_s)
    return [t for t in ticks_s if schedule.due(t, period_s)]


def lockstep_ticks(duration_s, start_s=TICK_S):
    return [round(start_s + k * TICK_S, 9) for k in range(int(round(duration_s / TICK_S)))]


def test_a_20_s_lockstep_run_has_twenty_lines_across_the_sine_s_range():
    times = said(lockstep_ticks(20.0))
    assert len(times) == 20  # the tutorial's rate: a line a second
    targets = np.sin(np.pi * np.asarray(times))  # the planner's 1 rad, 0.5 Hz sine at each line
    assert times[0] == TICK_S  # the first at the first tick, as before
    assert np.max(targets) > 0.9 and np.min(targets) < -0.9
    # Each second is half the sine's period, so the sign alternates; the size walks through 0 … 1 rad.
    sizes = np.sort(np.abs(targets))
    assert np.max(np.diff(np.concatenate([[0.0], sizes, [1.0]]))) < 0.3
    # Once at the same instant of every second, all twenty were within a few mrad of the zero crossing.
    assert np.sum(np.abs(targets) < 0.05) <= 2


def test_one_line_in_each_period_never_closer_than_the_step_allows():
    times = np.asarray(said(lockstep_ticks(200.0)))
    assert np.array_equal(np.floor(times - TICK_S + 1e-9), np.arange(200))  # one in each period
    gaps = np.diff(times)
    assert gaps.min() >= 1 - PHASE_STEP - TICK_S and gaps.max() <= 1 + PHASE_STEP + TICK_S


@pytest.mark.parametrize("k", [*range(40), 100, 1000])
def test_the_instant_walks_forward_and_back_within_the_period(k):
    assert 0.0 <= phase_in_period(k) <= LATEST_PHASE < 1.0
    step = abs(phase_in_period(k + 1) - phase_in_period(k))
    assert step == pytest.approx(PHASE_STEP) or step < PHASE_STEP  # a fold is a shorter step


def test_after_a_gap_in_the_ticks_one_line_and_the_schedule_goes_on():
    ticks = lockstep_ticks(3.0) + lockstep_ticks(3.0, start_s=9.005)  # nothing from 3 s to 9 s (a frozen host)
    times = said(ticks)
    resumed = [t for t in times if t > 3.0]
    assert resumed[0] == 9.005  # one line at once, not the six the gap spanned
    assert len(resumed) == 3 and min(np.diff(resumed)) >= 1 - PHASE_STEP - TICK_S  # periods afresh from it


def test_a_changed_period_counts_from_the_last_line():
    schedule = LogSchedule(1.0)
    ticks = lockstep_ticks(10.0)
    times = [t for t in ticks if schedule.due(t, 1.0 if t < 3.5 else 2.0)]
    before, after = [t for t in times if t < 3.5], [t for t in times if t >= 3.5]
    assert len(before) == 4
    assert after[0] >= before[-1] + 2.0 * (1 - PHASE_STEP) - TICK_S
    assert min(np.diff(after)) >= 2.0 * (1 - PHASE_STEP) - TICK_S


def test_the_line_keeps_the_tutorial_s_format():
    assert line([0.5871], [0.58249], [0.0046], [2.1591]) == "target=0.587, actual=0.582, error=0.005, torque=2.159"
    assert line([0.1, -0.2], [0.1, -0.2], [0.0, -0.0], [1.0, 2.0]) == (
        "target=0.100,-0.200, actual=0.100,-0.200, error=0.000,-0.000, torque=1.000,2.000"
    )
