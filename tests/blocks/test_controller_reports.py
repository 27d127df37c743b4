"""The controller block's reports (blocks/controller_reports.py, no ROS graph): a joint whose command stays cut by
its limit for more than SATURATION_SAID_AFTER_S is said once, a brief cut never; a start's wait; the margin's line.
The tutorial's log line: once per logging period, at an instant that walks through the period, so a lockstep run of
the 0.5 Hz sine shows the arm across its range (once at the same instant of every second, each line landed on the
sine's zero crossing)."""

from types import SimpleNamespace

import numpy as np
import pytest

from robot_controller.blocks import controller_reports as status
from robot_controller.blocks.controller_reports import (
    LATEST_PHASE,
    PHASE_STEP,
    SATURATION_SAID_AFTER_S,
    LogSchedule,
    Reports,
    SaturationWatch,
    law_in_force_line,
    phase_in_period,
)
from robot_controller.blocks.controller_reports import log_line as line

PERIOD_S = 0.01
TICK_S = 0.01


def said_over(watch, saturated_rows, start_s=0.0):
    said = []
    for k, row in enumerate(saturated_rows):
        said += [(round(start_s + k * PERIOD_S, 6), j) for j in watch.newly_long(start_s + k * PERIOD_S, row)]
    return said


def test_a_joint_saturated_for_longer_than_a_moment_is_said_once_by_name():
    watch = SaturationWatch(3)
    ticks = int(round(1.0 / PERIOD_S))  # a second of wrist saturation, as the PD law on the UR5 did
    said = said_over(watch, [np.array([0.0, 0.0, 1.0])] * ticks)
    assert said == [(round(SATURATION_SAID_AFTER_S, 6), 2)]
    assert said_over(watch, [np.array([0.0, 0.0, 1.0])] * ticks, start_s=2.0) == []  # once per run


def test_brief_cuts_are_not_said_and_a_break_restarts_the_count():
    watch = SaturationWatch(2)
    brief = int(SATURATION_SAID_AFTER_S / PERIOD_S) - 2  # just under the moment, then a tick free, again
    rows = ([np.array([1.0, 0.0])] * brief + [np.array([0.0, 0.0])]) * 5
    assert said_over(watch, rows) == []
    rows = [np.array([1.0, 1.0])] * (brief + 5)
    assert [j for _, j in said_over(watch, rows, start_s=10.0)] == [0, 1]


def test_a_prismatic_joint_is_said_cut_by_its_force_limit_in_newtons():
    said = []
    config = SimpleNamespace(pid=SimpleNamespace(output_limit=np.array([30.0, 10.0, 40.0])))
    names, units = ["shoulder", "elbow", "quill"], ["rad", "rad", "m"]
    reports = SimpleNamespace(joint_count=3, joint_names=names, joint_units=units)
    reports.controller, reports.saturation = SimpleNamespace(config=config), SaturationWatch(3)
    reports.log = SimpleNamespace(warning=said.append)
    for k in range(30):
        terms = SimpleNamespace(saturated=np.array([1.0, 0.0, 1.0]), command=np.array([30.0, 1.0, -40.0]))
        Reports.say_saturation(reports, SimpleNamespace(time_s=k * PERIOD_S, terms=terms))
    assert [line.split(": ")[0] for line in said] == ["shoulder", "quill"]
    assert "its torque limit (±30 N·m)" in said[0] and "more torque than" in said[0]
    assert "its force limit (±40 N)" in said[1] and "more force than" in said[1]


def test_a_start_s_wait_is_information_and_a_warning_only_once_it_lasts():
    clock = 100.0
    info, warnings = [], []
    log = SimpleNamespace(info=info.append, warn=lambda key, message: warnings.append((key, message)))
    waits = status.StartWaits(log)
    for _ in range(int(status.START_PATIENCE_S / PERIOD_S)):  # every tick of a slow start: said once, as information
        waits.waiting("readings", "the first valid /joint_states reading", clock)
        clock += PERIOD_S * 0.99
    assert info == ["waiting for the first valid /joint_states reading"] and warnings == []
    clock += 1.0
    waits.waiting("readings", "the first valid /joint_states reading", clock)
    assert len(warnings) == 1 and warnings[0][0] == "start_readings"
    assert warnings[0][1].startswith("still waiting after 11 s for the first valid /joint_states reading")


def test_a_delay_margin_of_one_period_is_said_in_the_singular():
    controller = SimpleNamespace(law_in_force=lambda: "PID")
    said = [law_in_force_line(controller, margin, 100.0) for margin in (1, 2)]
    assert "delay margin 1 control period (10 ms)" in said[0]
    assert "delay margin 2 control periods (20 ms)" in said[1]


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
