"""The end of a run from its metrics (no ROS): a verdict first, a dozen lines a person wants, a FAILED verdict
again last; ``summary.md``; step, compare and faults in the same shape, targets missed marked."""

from __future__ import annotations

import pytest

from robot_controller.scoring import summary

LOCKSTEP = {  # a clean 5 s lockstep run's metrics.json (the keys the end reads), with its timing.json
    "clock": "sim_lockstep",
    "robot": "one_dof",
    "preset": "default",
    "seed": 0,
    "duration_s": 5.0,
    "interrupted": False,
    "joint_names": ["joint1"],
    "joint_units": ["rad"],
    "tracking_rms_rad": 0.00099123,
    "tracking_max_rad": 0.0035712,
    "tracking_rms_per_joint": [0.00099123],
    "tracking_max_per_joint": [0.0035712],
    "scored_samples": 301,
    "peak_effort_per_joint": [3.5213],
    "peak_torque_nm": 3.5213,
    "control_rate_hz": 100.0,
    "jitter_p99_ms": 1.98973e-12,
    "missed_cycles": 0,
    "reacquiring_ticks": 77,  # the start: leading the arm onto its trajectory, not a fault
    "watchdog_ticks": 0,
    "stopped_ticks": 0,
    "saturated_ticks": 0,
    "malformed_messages": 0,
    "unrecorded_messages": 0,
    "real_time_factor": 1.7,
}


def end(values: dict, failure: str | None = None, **kwargs) -> list[str]:
    return summary.lines(summary.verdict(failure), summary.run_rows(values, **kwargs))


def test_a_lockstep_run_ends_with_its_verdict_and_a_few_lines_in_mrad():
    said = end(LOCKSTEP, effort_limits=[10.0], out="runs/r5")
    assert said[0] == "ok" and len(said) - 1 <= 14
    text = "\n".join(said)
    assert "RMS 0.991 mrad, max 3.57 mrad" in text and "true angle" in text
    assert " s on sim time (--sim-time), " in said[1], said[1]
    assert "3.52 N·m of 10 N·m (35 %)" in text
    assert "robot-controller score runs/r5 --all" in text and "runs/r5/: summary.md" in text
    # What lockstep makes meaningless, and what is normal, is not said.
    assert not any(line.startswith(("rate", "faults", "jitter")) for line in said), text
    assert "reacquiring" not in text and "e-12" not in text


def test_off_lockstep_the_rate_and_misses_are_said_and_faults_only_when_there_were_any():
    wall = LOCKSTEP | {"clock": "wall", "control_rate_hz": 99.97, "missed_cycles": 1, "jitter_p99_ms": 0.214}
    rows = dict(summary.run_rows(wall))
    assert rows["rate"] == "100.0 Hz, 1 missed cycle, jitter p99 0.21 ms"
    rows = dict(summary.run_rows(wall | {"missed_cycles_host": 80}))
    assert rows["rate"] == "100.0 Hz, 1 missed cycle (80 more the host made, not counted), jitter p99 0.21 ms"
    assert "faults" not in rows and "host freezes" not in rows and "brakes" not in rows
    paced = LOCKSTEP | {"clock": "sim_paced", "late_efforts": 2, "host_freezes": 3, "host_freeze_ms_max": 41.2}
    paced |= {"host_freeze_ms_total": 80.0, "watchdog_ticks": 4, "stopped_ticks": 1, "unrecorded_messages": 3}
    paced |= {"brake_engagements": 1, "braked_s": 0.4612, "late_efforts_host": 7, "stale_efforts": 1}
    rows = dict(summary.run_rows(paced))
    assert rows["rate"].startswith("100.0 Hz, 0 missed cycles, 2 late efforts")
    assert rows["rate"].endswith(
        "; 7 efforts the host made late (not counted); 1 stale effort dropped (the world had moved on)"
    )
    assert rows["faults"] == "watchdog 4 ticks, e-stopped (asked for) 1 tick"
    assert rows["host freezes"].startswith("3, the longest 41 ms, 80 ms in all")
    assert rows["brakes"] == "held the arm 1 time, 0.46 s in all (not scored as tracking)"
    assert rows["recording"] == "3 published messages missing from the bag"
    host = {"watchdog_ticks_host": 2, "stopped_ticks": 1}
    rows = dict(summary.run_rows(wall | host))
    assert rows["faults"] == "watchdog: 2 ticks the host made (not counted), e-stopped (asked for) 1 tick"
    rows = dict(summary.run_rows(wall | host | {"watchdog_ticks": 1}))
    assert rows["faults"] == "watchdog 1 tick (2 more the host made, not counted), e-stopped (asked for) 1 tick"


def test_a_failing_run_says_failed_first_and_last():
    said = end(LOCKSTEP | {"law_stopped_ticks": 12}, "the control law failed: ZeroDivisionError")
    assert said[0] == said[-1] == "FAILED: the control law failed: ZeroDivisionError"
    assert any(line.startswith("faults") and "law stopped 12 ticks" in line for line in said)


def test_a_chain_names_its_worst_joint_and_the_one_nearest_its_effort_limit():
    chain = LOCKSTEP | {
        "joint_names": ["shoulder", "elbow", "quill"],
        "joint_units": ["rad", "rad", "m"],
        "tracking_rms_per_joint": [0.001, 0.002, 0.0004],
        "tracking_max_per_joint": [0.005, 0.003, 0.0009],
        "peak_effort_per_joint": [20.0, 9.0, 12.0],
    }
    rows = dict(summary.run_rows(chain, effort_limits=[30.0, 10.0, 40.0]))
    assert rows["tracking"].startswith(
        "RMS 2 mrad on elbow, max 5 mrad on shoulder; RMS 0.4 mm on quill, max 0.9 mm on quill: the worst of 3 joints"
    )
    assert rows["peak effort"].startswith("9 N·m of 10 N·m (90 %) on elbow, the nearest its limit")


def test_a_run_shorter_than_the_warm_up_says_it_was_not_scored():
    rows = dict(summary.run_rows(LOCKSTEP | {"scored_samples": 0, "tracking_rms_rad": None}))
    assert rows["tracking"] == "not scored: nothing after the 2 s start"


def test_summary_md_holds_the_verdict_the_command_the_figures_and_links():
    rows = summary.run_rows(LOCKSTEP, effort_limits=[10.0], out="runs/r5")
    text = summary.markdown(
        "ok",
        rows,
        title="Run r5",
        command="robot-controller run --sim-time --duration 5",
        links=["tracking.png", "bag/"],
    )
    assert text.startswith("# Run r5\n\n**ok**")
    assert "robot-controller run --sim-time --duration 5" in text
    assert "one_dof, preset default, seed 0" in text and "RMS 0.991 mrad" in text
    assert "[tracking.png](tracking.png)" in text and "[bag/](bag/)" in text


STEP = {"amplitude_rad": 0.5, "step_shaping": "min_time", "seed": 0, "joint_names": ["joint1"]}
STEP |= {"overshoot_pct": 0.46, "rise_time_s": 0.112, "steady_state_error_rad": 0.001, "peak_torque_nm": 7.0}


@pytest.mark.parametrize("settling_s", [0.19, 0.296, float("nan")])
def test_a_step_marks_the_reference_arms_targets_it_missed(settling_s):
    rows = dict(summary.step_rows(STEP | {"settling_time_s": settling_s}, robot="one_dof", effort_limits=[10.0]))
    missed = not settling_s <= 0.25
    assert (summary.MISSED in rows["settling 2 %"], summary.MISSED in rows["overshoot"]) == (missed, False)
    assert rows["peak effort"] == "7 N·m of 10 N·m (70 %)"
    # Another arm has no such targets.
    assert summary.MISSED not in str(summary.step_rows(STEP | {"settling_time_s": settling_s}, robot="panda"))


def test_compare_marks_each_contenders_missed_target():
    table = {
        "lqr": {"sine_tracking_rms_rad": {"mean": 0.0008}, "step_settling_time_s": {"mean": 0.19}},
        "default": {"sine_tracking_rms_rad": {"mean": 0.001}, "step_settling_time_s": {"mean": 0.296}},
        "tutorial": {"sine_tracking_rms_rad": {"mean": 0.226}, "step_settling_time_s": {"mean": None}},
    }
    assert summary.compare_missed(table, "one_dof") == [
        f"{summary.MISSED}: default: step settling 0.296 s (target ≤ 0.25 s)",
        f"{summary.MISSED}: tutorial: sine RMS 226 mrad (target ≤ 1.5 mrad)",
        f"{summary.MISSED}: tutorial: step settling never settled (target ≤ 0.25 s)",
    ]
    assert summary.compare_missed(table, "panda") == []


def test_faults_in_a_few_lines_the_missed_cases_named():
    entries = [
        {"case": f"node{k}_stop_0.5s", "max_deviation_rad": 0.001 * k, "reacquire_s": 0.1 * k, "brake_engaged": k % 2}
        | ({"world": "paced"} if k < 8 else {})  # a faults.json of before the world was said: the wall clock's
        for k in range(1, 9)
    ]
    failed = [f"node{k}_stop_0.5s: joint1 left its band by 0.2 rad" for k in range(1, 8)]
    rows = summary.faults_rows(entries, failed, 0.1)
    said = dict(rows)
    assert said["worst deviation"] == "8 mrad (node8_stop_0.5s), goal ≤ 100 mrad"
    assert said["brakes engaged"] == "in 4 of 8 cases"
    assert said["world"] == "paced (7 cases), wall clock (1 case)"
    assert said["re-acquired"].startswith("within 0.80 s")
    missed = [text for label, text in rows if label == "missed"]
    assert missed[:5] == failed[:5] and missed[5] == "2 more in faults.md" and len(rows) <= 12


def test_a_run_with_pushes_says_what_the_band_judged_and_the_start_what_it_did():
    values = {
        "scored_samples": 800,
        "tracking_rms_rad": 0.002,
        "tracking_max_rad": 0.0113,
        "unpushed_max_per_joint": [0.00357],
        "start_tracking_max_per_joint": [0.00155],
        "start_transient_end_s": 0.0,
        "tracking_band_rad": 0.006,
    }
    rows = dict(summary.run_rows(values))
    assert rows["pushes"] == "max 3.57 mrad without each push and the 1 s after it (what the band judges)"
    assert rows["start"] == "max 1.55 mrad in the first 2 s, no worse than after it (band 6 mrad)"
    rows = dict(summary.run_rows(values | {"start_transient_end_s": 1.25}))
    assert rows["start"] == "max 1.55 mrad in the first 2 s, no worse than after it from 1.25 s (band 6 mrad)"


def test_on_a_robot_the_rate_is_its_own_count_and_our_time_per_tick():
    robot = LOCKSTEP | {"clock": "wall", "hardware": "franka://127.0.0.1", "control_rate_hz": 99.9}
    robot |= {"robot_missed_cycles": 3.0, "command_success_rate": 0.99951, "command_success_rate_min": 0.97}
    robot |= {"tick_compute_p50_ms": 0.46, "tick_compute_p99_ms": 0.83, "tick_compute_max_ms": 2.1}
    robot |= {"host_steal_pct": 0.012}
    rows = dict(summary.run_rows(robot))
    assert rows["rate"] == (
        "1 kHz by the robot's clock (recorded at 100 Hz), 3 periods missed by its count: it took 0.99951 of the "
        "commands in time (its 100-command low 0.97); our tick 0.46 ms p50, 0.83 p99, 2.10 max of its 1 ms; the "
        "hypervisor took 0.01 % of this host"
    )
