"""The controller block's reports (blocks/controller_reports.py, no ROS graph): a joint whose command stays cut by
its limit for more than SATURATION_SAID_AFTER_S is said once, a brief cut never; a start's wait; the margin's line."""

from types import SimpleNamespace

import numpy as np

from robot_controller.blocks import controller_reports as status
from robot_controller.blocks.controller_reports import (
    SATURATION_SAID_AFTER_S,
    Reports,
    SaturationWatch,
    law_in_force_line,
)

PERIOD_S = 0.01


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
