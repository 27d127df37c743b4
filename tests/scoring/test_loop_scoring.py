"""The in-process loop's record scored as a sim-time run's bag is (no ROS): the same samples, both ends in."""

import dataclasses

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller.core.controller import state_layout
from robot_controller.experiments import inprocess
from robot_controller.scoring import loop_scoring, report

PERIOD_S = 0.01


@pytest.fixture(scope="module")
def run():
    return inprocess.simulate(cfg.load_stack("default"), duration_s=3.0 + PERIOD_S, seed=2)


def test_the_window_holds_the_state_at_the_runs_end_as_the_graphs_scorer_does(run):
    figures = loop_scoring.tracking(run, 3.0, PERIOD_S)
    assert figures["scored_samples"] == 101  # 2.00 s to 3.00 s, both in
    # The end's sample is scored: its error alone is the maximum when it is made the largest.
    moved = run.true_position.copy()
    moved[-1] += 0.1
    recording = loop_scoring.as_recording(dataclasses.replace(run, true_position=moved))
    assert report.tracking_on_sim_timeline(recording, 2.0, 3.0, PERIOD_S)["tracking_max_rad"] > 0.09
    assert figures["start_tracking_max_rad"] >= 0 and np.isfinite(figures["tracking_rms_rad"])


def test_each_ticks_status_is_recorded(run):
    assert len(run.status_code) == len(run.tick_time_s)
    assert run.status_code[-1] == state_layout.STATUS_CODES["ok"]


def test_a_loop_that_stops_short_of_the_end_is_refused(run):
    with pytest.raises(ValueError, match="needs its tick at the end"):
        loop_scoring.tracking(run, 3.5, PERIOD_S)
