"""One scored run: a launched run and a saved one re-scored give the same figures and verdict, the host's share of
the watchdog ticks and missed cycles set apart on every clock but lockstep."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller.core.controller import state_layout
from robot_controller.runner.options import RunOptions
from robot_controller.runner.supervise import RunResult
from robot_controller.scoring import report, scored_run
from tests.scoring.test_per_joint import synthetic_recording

WATCHDOG_AT_S = (3.0, 3.01, 3.02)  #: the ticks (s) a frozen host made the watchdog's


def watchdog_recording():
    """6 s tracked within 2 mrad, three watchdog ticks at 3 s."""
    recording = synthetic_recording([0.002], ["joint1"])
    status = recording.state["status"]
    status[np.isin(np.round(recording.state["time_s"], 6), WATCHDOG_AT_S)] = state_layout.STATUS_CODES["watchdog"]
    return recording


@pytest.mark.parametrize("clock", ["wall", "sim_paced", "sim_lockstep"])
def test_a_launched_runs_watchdog_ticks_the_host_made_are_counted_apart(monkeypatch, tmp_path, clock):
    monkeypatch.setattr(report, "read_recording", lambda path: watchdog_recording())
    options = RunOptions(6.0, paced=clock == "sim_paced", sim_time=clock == "sim_lockstep")
    checked = SimpleNamespace(options=options, params=cfg.load_stack())
    result = RunResult(tmp_path / "bag", True, options.nodes or ())
    result.control_seconds = result.wall_seconds = 6.0
    result.host_watchdog_s = [] if clock == "sim_lockstep" else list(WATCHDOG_AT_S)
    scored = scored_run.score_launched(checked, result)
    assert scored.metrics["clock"] == clock
    if clock == "sim_lockstep":  # no host in lockstep: the loop's own, and judged so
        assert scored.metrics["watchdog_ticks"] == 3 and "watchdog_ticks_host" not in scored.metrics
        assert scored.verdict.line == "FAILED: stops nobody asked for (watchdog 3 ticks)"
        assert "real_time_factor" in scored.timing and "real_time_factor" not in scored.metrics
    else:
        assert (scored.metrics["watchdog_ticks"], scored.metrics["watchdog_ticks_host"]) == (0, 3)
        assert scored.verdict.ok and not scored.timing
        assert scored.judged["verdict"] == "ok" and scored.judged["tracking_band_rad"] == pytest.approx(0.02)


def test_a_saved_run_is_re_judged_with_its_hosts_share_and_its_failure(monkeypatch, tmp_path):
    monkeypatch.setattr(report, "read_recording", lambda path: watchdog_recording())
    saved = {"clock": "wall", "duration_s": 6.0, "joint_units": ["rad"]}
    (tmp_path / "metrics.json").write_text(json.dumps(saved))
    assert scored_run.rescore(tmp_path).verdict.line == "FAILED: stops nobody asked for (watchdog 3 ticks)"
    (tmp_path / "metrics.json").write_text(json.dumps(saved | {"watchdog_ticks_host": 3}))
    scored = scored_run.rescore(tmp_path)
    assert scored.verdict.ok and (scored.metrics["watchdog_ticks"], scored.metrics["watchdog_ticks_host"]) == (0, 3)
    (tmp_path / "metrics.json").write_text(json.dumps(saved | {"run_failure": "node died: motor_node (exit code 1)"}))
    assert scored_run.rescore(tmp_path).verdict.line == "FAILED: node died: motor_node (exit code 1)"
