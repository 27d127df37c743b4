"""Campaign runs that cannot hang: a law of one's own contained in the in-process loop as in the graph (a law that
blocks, spins or returns NaN faults its run into a controlled stop), a run stuck in C code killed at its wall-time
limit and tried once more, and a resume refused in one line when a file the campaign names changed. No ROS."""

from __future__ import annotations

import subprocess
import sys
import textwrap
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml

from robot_controller import parameters as cfg
from robot_controller.core.controller import Status
from robot_controller.experiments import inprocess
from robot_controller.experiments.laws import with_controller

LAWS = textwrap.dedent(
    """
    import ctypes
    import time

    import numpy as np

    from robot_controller.core.laws import ControlLaw


    class Tracks(ControlLaw):
        '''A PD law with gravity; in a world whose arm starts at 0.2 rad it goes wrong 0.5 s in (``misbehave``).'''

        def reset(self, state):
            self.odd_world = abs(float(state.position[0]) - 0.2) < 0.05

        def update(self, time_s, state, reference):
            if getattr(self, "odd_world", False) and time_s > 0.5:
                self.misbehave()
            error, rate = reference.position - state.position, reference.velocity - state.velocity
            return 30.0 * error + 3.0 * rate + self.arm.gravity(state.position)

        def misbehave(self):
            pass


    class Sleeps(Tracks):
        def misbehave(self):
            time.sleep(1e9)


    class Spins(Tracks):
        def misbehave(self):
            while True:
                pass


    class Nan(Tracks):
        def update(self, time_s, state, reference):
            torque = super().update(time_s, state, reference)
            return torque * np.nan if getattr(self, "odd_world", False) and time_s > 0.5 else torque


    class StuckInC(Tracks):
        def misbehave(self):
            ctypes.PyDLL(None).sleep(1000000)  # holds the GIL: no thread of its process runs again
    """
)
#: Campaign seed 6 draws [0.0, 0.2, 0.0] for these runs: only run 1's world makes the law go wrong.
SPEC = {
    "robot": "one_dof",
    "duration_s": 2.5,
    "runs": 3,
    "seed": 6,
    "vary": {"simulator.initial_position": {"choice": [0.0, 0.2]}},
    "pass": {"tracking_rms_rad": 0.05},
}


@pytest.fixture
def laws(tmp_path) -> Path:
    path = tmp_path / "laws.py"
    path.write_text(LAWS)
    return path


def spec_file(folder: Path, law: str, **changes) -> Path:
    path = folder / "campaign.yaml"
    path.write_text(yaml.safe_dump({**SPEC, "controller": f"laws.py:{law}", **changes}, sort_keys=False))
    return path


@pytest.mark.parametrize(
    "law, said",
    [
        ("Sleeps", "was still in update() after 1000.0 ms"),
        # Abandoned once it has computed a period past its budget; on a host so busy that its thread computed less
        # than that within 1 s of wall time, at the wall-time limit (seen once beside four other test sessions).
        ("Spins", "over its budget of 5 ms"),
        ("Nan", "returned a non-finite torque"),
    ],
)
def test_a_law_that_goes_wrong_in_process_faults_its_run_into_a_controlled_stop(laws, law, said):
    params = with_controller(cfg.load_stack("default", None, "one_dof"), f"{laws}:{law}")
    params = cfg.merge(params, {"simulator": {"initial_position": [0.2]}})
    loop = inprocess.prepare(params, duration_s=2.0)
    statuses = []
    controller = loop.keywords["controller"]

    class Watched:
        def __getattr__(self, name):
            return getattr(controller, name)

        def update(self, now_s):
            out = controller.update(now_s)
            statuses.append(out.status)
            return out

    result = loop(controller=Watched())
    assert result.law_fault is not None and said in result.law_fault and "at t = 0.5" in result.law_fault
    assert len(statuses) == 200  # the run went to its end
    assert Status.LAW_FAULT in statuses and statuses[-1] is Status.LAW_STOPPED  # category 2, then 1
    assert np.all(result.command[-10:] == 0.0)


def test_a_sound_law_of_ones_own_runs_in_process_without_a_fault(laws):
    params = with_controller(cfg.load_stack("default", None, "one_dof"), f"{laws}:Sleeps")
    result = inprocess.simulate(params, duration_s=3.0)  # its world starts at 0: it never sleeps
    assert result.law_fault is None
    assert result.tracking_metrics()["tracking_rms_rad"] < 0.05


def test_runs_one_after_another_leave_no_law_thread_behind(laws):
    import gc
    import threading

    spec = f"{laws}:Tracks"  # this test's own file: its law's threads are named after it
    params = with_controller(cfg.load_stack("default", None, "one_dof"), spec)

    def law_threads() -> int:
        return sum(t.name == f"law {spec}" for t in threading.enumerate())

    for _ in range(3):
        loop = inprocess.prepare(params, duration_s=0.5)
        assert law_threads() >= 1  # the law's calls run on a thread of its own
        loop()
    del loop
    gc.collect()
    deadline = time.monotonic() + 5
    while law_threads() and time.monotonic() < deadline:
        time.sleep(0.01)  # a worker's thread ends at its next look at its queue
    assert law_threads() == 0


def test_a_campaign_whose_law_blocks_in_one_run_finishes_that_run_a_law_fault(laws, tmp_path):
    from robot_controller.experiments.campaign import campaign, report
    from robot_controller.experiments.campaign.spec import load_spec

    spec = load_spec(spec_file(laws.parent, "Sleeps"))
    (tmp_path / "out").mkdir()
    store = campaign.run_campaign(spec, tmp_path / "out", workers=2, say=lambda line: None)
    rows = {r["run_id"]: r for r in store.rows}
    assert [rows[k]["simulator.initial_position"] for k in range(3)] == [0.0, 0.2, 0.0]
    assert all(r["status"] == "ok" and r["attempts"] == 1 for r in rows.values())
    assert "Sleeps was still in update()" in rows[1]["law_fault"] and "abandoned at t = 0.5" in rows[1]["law_fault"]
    assert rows[0]["law_fault"] == rows[2]["law_fault"] == ""
    assert [report.passes(rows[k], spec.pass_bounds) for k in range(3)] == [True, False, True]
    text = report.write_report(spec, store.rows, tmp_path / "out", [""]).read_text()
    assert "## Law faults" in text and "- run 1: control law" in text


def test_a_run_stuck_in_c_is_killed_at_its_limit_tried_again_and_recorded_as_timed_out(laws, tmp_path):
    from robot_controller.experiments.campaign import campaign
    from robot_controller.experiments.campaign.spec import load_spec

    spec = load_spec(spec_file(laws.parent, "StuckInC", run_timeout_s=4))
    assert spec.timeout_s == 4.0
    (tmp_path / "out").mkdir()
    store = campaign.run_campaign(spec, tmp_path / "out", workers=2, say=lambda line: None)
    rows = {r["run_id"]: r for r in store.rows}
    stuck = rows[1]
    assert stuck["status"] == "timed_out" and stuck["attempts"] == 2
    assert stuck["reason"].startswith("timed out: still running after 4 s of wall time")
    assert stuck["first_failure"] == stuck["reason"] and stuck["wall_s"] >= 4.0
    assert rows[0]["status"] == rows[2]["status"] == "ok"
    assert rows[0]["attempts"] == rows[2]["attempts"] == 1 and rows[0]["first_failure"] == ""


def test_a_run_that_fails_is_tried_once_more_and_keeps_both_reasons(monkeypatch):
    from robot_controller.experiments.campaign import executors

    tries = []

    def flaky(task):
        tries.append(task.run_id)
        row = executors.head(task)
        if len(tries) == 1:
            return {**row, "status": "failed", "reason": "RuntimeError: the first try"}
        return {**row, "status": "ok", "reason": ""}

    monkeypatch.setattr(executors, "attempt", flaky)
    task = executors.Task(7, "", {}, {}, 1, 1.0)
    row = executors.run(task)
    assert tries == [7, 7] and row["status"] == "ok"
    assert row["attempts"] == 2 and row["first_failure"] == "RuntimeError: the first try"


def test_the_default_limit_grows_with_the_run_and_a_bad_one_is_refused(tmp_path, laws):
    from robot_controller.core.errors import ConfigError
    from robot_controller.experiments.campaign.spec import load_spec

    short, long = (load_spec(spec_file(laws.parent, "Tracks", duration_s=d)).timeout_s for d in (1, 30))
    assert 60 < short < long
    with pytest.raises(ConfigError, match=r"run_timeout_s: expected a run's wall-time limit"):
        load_spec(spec_file(laws.parent, "Tracks", run_timeout_s=0))


def campaign_cli(*args) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "robot_controller.cli", "campaign", *map(str, args)]
    return subprocess.run(command, capture_output=True, text=True, timeout=180)


def test_resuming_after_the_law_file_changed_is_refused_in_one_line(laws, tmp_path):
    from robot_controller.experiments.campaign import campaign
    from robot_controller.experiments.campaign.spec import load_spec

    spec = spec_file(laws.parent, "Tracks", runs=2)
    out = tmp_path / "out"
    out.mkdir()
    campaign.run_campaign(load_spec(spec), out, workers=1, say=lambda line: None)
    assert campaign.open_store(load_spec(spec), out).done() == {("", 0), ("", 1)}  # unchanged: it resumes
    laws.write_text(LAWS.replace("30.0 * error", "31.0 * error"))
    refused = campaign_cli(spec, "--out", out, "--workers", 1)
    said = (refused.stdout + refused.stderr).strip()
    assert refused.returncode == 2 and len(said.splitlines()) == 1, said
    assert f"the law file {laws.resolve()}: its contents changed" in said and "not resumed" in said
    assert "Traceback" not in said


def test_the_fingerprint_names_each_part_that_changed(laws, tmp_path):
    from robot_controller.experiments.campaign import store
    from robot_controller.experiments.campaign.spec import load_spec

    config = laws.parent / "arm.yaml"
    config.write_text("pid_controller:\n  ros__parameters:\n    kp: 40.0\n")
    spec = load_spec(spec_file(laws.parent, "Tracks", config="arm.yaml"))
    before = store.parts(spec, (spec.controller,))
    assert any(what.startswith("the URDF ") for what in before)
    config.write_text("pid_controller:\n  ros__parameters:\n    kp: 41.0\n")
    after = store.parts(replace(spec, seed=7), (spec.controller,))
    said = store.changed(before, after)
    assert said == [store.SPEC + " changed", f"the config file {config.resolve()}: its contents changed"]
    other_code = {**after, store.CODE: "0.0.1 (source 0, mujoco 3)"}
    assert store.changed(other_code, after) == [
        f"robot_controller: 0.0.1 (source 0, mujoco 3) then, {after[store.CODE]} now"
    ]


def test_a_workers_warm_up_that_fails_or_overruns_is_abandoned_and_made_once(monkeypatch):
    """The warm-up runs in the worker itself, unguarded by a fork: past its limit it is given up, as is one that
    raises; either way once per worker, and the runs go on."""
    from robot_controller.experiments.campaign import executors

    calls = []

    def spins(*args):
        calls.append(args)
        while True:
            time.sleep(0.01)

    monkeypatch.setattr(executors, "_warmed", False)
    monkeypatch.setattr(executors, "WARM_UP_TIMEOUT_S", 0.3)
    monkeypatch.setattr(executors, "figures", spins)
    task = executors.Task(0, "", {}, {}, 1, 1.0)
    start = time.monotonic()
    executors.warm_up(task)
    executors.warm_up(task)
    assert len(calls) == 1 and time.monotonic() - start < 5.0

    def raises(*args):
        raise RuntimeError("a world the stack refuses")

    monkeypatch.setattr(executors, "_warmed", False)
    monkeypatch.setattr(executors, "figures", raises)
    executors.warm_up(task)  # nothing raised
