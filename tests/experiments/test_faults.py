"""The faults report without a graph: each joint judged in its own unit against the 0.1 band, and a case
that misses it makes the verb fail, naming the case and the joint."""

from __future__ import annotations

import numpy as np
import pytest

from robot_controller import cli
from robot_controller.core.controller import state_layout
from robot_controller.experiments import faults
from robot_controller.runner.supervise import RunResult
from robot_controller.scoring.bag_reader import Recording

NAMES, UNITS = ["shoulder", "elbow", "quill"], ["rad", "rad", "m"]


def recording_with_drift(drift: list[float], fault_s: float = 3.0) -> Recording:
    """6 s of a 0.5 Hz sine of amplitude [0.6 rad, 0.8 rad, 0.05 m] tracked exactly until ``fault_s``, then each
    joint drifting to ``drift`` past its band's upper edge."""
    t = np.arange(0.0, 6.0, 0.01)
    amplitude = np.array([0.6, 0.8, 0.05])
    planned = np.sin(np.pi * t)[:, None] * amplitude
    ramp = np.clip(t - fault_s, 0.0, 1.0)[:, None]
    true = planned * (1 - ramp) + ramp * (amplitude + np.asarray(drift))
    values = {name: np.zeros((len(t), 3)) for name in state_layout.FIELDS} | {"reference": planned}
    values["command"] = np.tile([2.0, -1.0, 9.8], (len(t), 1))
    rows = np.column_stack(
        [t, np.full(len(t), state_layout.STATUS_CODES["ok"]), t] + [values[name] for name in state_layout.FIELDS]
    )
    return Recording(
        state=state_layout.decode(rows, 3),
        true_time_s=t,
        true_position=true,
        true_velocity=np.zeros_like(true),
        true_effort=values["command"],
        planned_time_s=t,
        planned_position=planned,
        recorded_joint_names=NAMES,
    )


def test_each_joint_is_judged_in_its_unit_and_the_one_out_of_its_band_is_named():
    figures = faults.case_figures(recording_with_drift([0.05, 0.0, 0.15]), 3.0, 3.5, UNITS)
    assert figures["max_deviation_per_joint"] == pytest.approx([0.05, 0.0, 0.15])
    assert figures["max_deviation_rad"] == pytest.approx(0.05) and figures["max_deviation_m"] == pytest.approx(0.15)
    assert "max_deviation_rad_per_joint" not in figures  # its list would mix rad and m
    assert figures["peak_torque_nm"] == pytest.approx(2.0) and figures["peak_force_n"] == pytest.approx(9.8)
    assert figures["band_missed"] == "quill left its band by 0.1500 m (goal ≤ 0.1 m)"
    within = faults.case_figures(recording_with_drift([0.05, 0.0, 0.02]), 3.0, 3.5, UNITS)
    assert "band_missed" not in within and within["max_deviation_m"] == pytest.approx(0.02)


def test_a_revolute_arm_keeps_its_keys():
    figures = faults.case_figures(recording_with_drift([0.2, 0.0, 0.0]), 3.0, 3.5)
    assert figures["max_deviation_rad_per_joint"] == pytest.approx([0.2, 0.0, 0.0])
    assert "max_deviation_m" not in figures and figures["peak_torque_nm"] == pytest.approx(9.8)
    assert figures["band_missed"] == "shoulder left its band by 0.2000 rad (goal ≤ 0.1 rad)"


@pytest.mark.parametrize("missed", [True, False])
def test_faults_exits_1_naming_the_case_and_joint_that_left_its_band(tmp_path, monkeypatch, capsys, missed):
    entry = {"case": "sensor_node_stop_0.5s", "node": "sensor_node", "fault": "SIGSTOP", "duration_s": 0.5}
    entry |= {"exit_code": 0, "max_deviation_rad": 0.001}
    if missed:
        entry["band_missed"] = "quill left its band by 0.1500 m (goal ≤ 0.1 m)"

    def fake_faults(out, **_):
        (out / "faults.md").write_text(faults.render([entry]))
        return [entry]

    monkeypatch.setattr(faults, "faults", fake_faults)
    code = cli.main(["faults", "--quick", "--out", str(tmp_path / "faults")])
    said = capsys.readouterr()
    failed = "robot-controller faults: FAILED: sensor_node_stop_0.5s: quill left its band by 0.1500 m"
    assert (code, failed in said.err) == (int(missed), missed)
    # The end: the verdict first and last, the case named between, every case in faults.md.
    end = said.out.splitlines()
    verdict = "FAILED: 1 of 1 cases missed their goal" if missed else "ok"
    assert end[0] == verdict and end[-1].startswith(verdict if missed else "files") and len(end) <= 14, end
    assert any("sensor_node_stop_0.5s: quill left its band" in line for line in end) == missed, end


def test_a_freeze_is_placed_on_the_paced_worlds_time_which_stands_while_the_world_is_paused():
    result = RunResult(bag_dir=None, recorded=True, local_nodes=())
    # The recorder's reports: (monotonic s, world s); the world paused from 100.2 to 100.6 (its simulator frozen).
    result.clock_marks = [(100.0, 5.0), (100.1, 5.1), (100.2, 5.2), (100.6, 5.21), (100.7, 5.31)]
    assert np.isnan(result.world_time_at(99.9))  # before the loop's first report: unknown
    assert result.world_time_at(100.05) == pytest.approx(5.05)
    assert result.world_time_at(100.25) == pytest.approx(5.21)  # a freeze starting: never past the next tick
    assert result.world_time_at(100.55, resuming=True) == pytest.approx(5.2)  # one ending: the world stood
    assert result.world_time_at(100.65, resuming=True) == pytest.approx(5.26)  # counted back from the next tick
    assert result.world_time_at(100.75) == pytest.approx(5.36)  # after the last, at the world's pace


def test_brakes_stamped_on_the_worlds_tick_just_before_the_fault_started_count():
    recording = recording_with_drift([0.0, 0.0, 0.0])
    recording.brakes_time_s, recording.brakes = np.array([0.0, 2.99, 3.4]), np.array([[0.0], [1.0], [0.0]])
    assert faults.case_figures(recording, 3.0, 3.5, UNITS)["brake_engaged"]  # in force at the start
    recording.brakes = np.array([[0.0], [0.0], [0.0]])
    assert not faults.case_figures(recording, 3.0, 3.5, UNITS)["brake_engaged"]


@pytest.mark.parametrize("wall_clock", [False, True])
def test_freezes_strike_the_default_runs_paced_world_and_kills_the_wall_clock(wall_clock):
    freeze, kill = faults.Case("sensor_node", 0.5), faults.Case("sensor_node", 0.0, "SIGKILL")
    assert faults.world_of(freeze, wall_clock) == ("wall clock" if wall_clock else "paced")
    assert faults.world_of(kill, wall_clock) == "wall clock"  # respawned: a new simulator would restart world time
    entry = {"case": freeze.name, "node": "sensor_node", "fault": "SIGSTOP", "duration_s": 0.5, "exit_code": 0}
    page = faults.render([entry | {"world": faults.world_of(freeze, wall_clock)}], wall_clock=wall_clock)
    assert ("freezes on the wall clock" in page) == wall_clock and ("freezes in the paced world" in page) != wall_clock
    assert "| world |" in page and f"| frozen 0.5 s | {faults.world_of(freeze, wall_clock)} |" in page
