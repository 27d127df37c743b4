"""A small one-joint campaign, run for real: the local pool's rows equal a real Ray cluster's (a head started here on
free ports), a campaign killed with SIGKILL part-way and started again ends with each run once and the figures of an
uninterrupted one, and campaign.md holds its sections. No ROS (the in-process loop)."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from dataclasses import replace
from pathlib import Path

import pyarrow.parquet as pq
import pytest
import yaml

from robot_controller.experiments.campaign.executors import HOST_COLUMNS

RUNS = 12
SPEC = {
    "robot": "one_dof",
    "duration_s": 2.5,
    "runs": RUNS,
    "seed": 3,
    "vary": {
        "sensor_node.delay_s": {"uniform": [0.0, 0.03]},
        "sensor_node.position_noise_std": {"loguniform": [0.001, 0.02]},
        "motor_node.lag_time_constant_s": {"uniform": [0.0, 0.02]},
    },
    "pass": {"tracking_rms_rad": 0.005},
}


def campaign(*args: str, **popen) -> subprocess.Popen:
    command = [sys.executable, "-m", "robot_controller.cli", "campaign", *map(str, args)]
    return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **popen)


def finished(process: subprocess.Popen, timeout_s: float = 180) -> str:
    out, _ = process.communicate(timeout=timeout_s)
    assert process.returncode == 0, out
    return out


def figures(folder: Path) -> list[dict]:
    """The rows without what the host decides (the wall time), in run order."""
    rows = pq.read_table(folder / "results.parquet").to_pylist()
    return sorted(({k: v for k, v in r.items() if k not in HOST_COLUMNS} for r in rows), key=lambda r: r["run_id"])


@pytest.fixture(scope="module")
def spec_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("spec") / "campaign.yaml"
    path.write_text(yaml.safe_dump(SPEC, sort_keys=False))
    return path


@pytest.fixture(scope="module")
def local(spec_file, tmp_path_factory) -> Path:
    """The campaign on two local workers, uninterrupted."""
    out = tmp_path_factory.mktemp("local") / "c"
    said = finished(campaign(spec_file, "--out", out, "--workers", 2))
    assert f"{RUNS} of {RUNS} runs finished" in said, said
    return out


def test_the_campaign_writes_every_run_once_and_its_report(local):
    rows = figures(local)
    assert [r["run_id"] for r in rows] == list(range(RUNS))
    assert all(r["status"] == "ok" for r in rows), [r["reason"] for r in rows]
    assert len({r["sensor_node.delay_s"] for r in rows}) == RUNS  # each run its own world
    assert all(0 < r["tracking_rms_rad"] < r["tracking_max_rad"] < 0.1 for r in rows)
    text = (local / "campaign.md").read_text()
    for section in ("## Figures", "## Pass rate", "Wilson", "## Worst runs", "## Sensitivity", "spearmanr"):
        assert section in text
    assert (local / "distributions.png").stat().st_size > 0 and (local / "sensitivity.png").stat().st_size > 0


def test_the_same_command_again_runs_nothing(local, spec_file):
    before = figures(local)
    said = finished(campaign(spec_file, "--out", local, "--workers", 2))
    assert f"resuming: {RUNS} of {RUNS} runs already" in said
    assert figures(local) == before


def test_another_spec_on_the_same_folder_is_refused(local, spec_file, tmp_path):
    other = tmp_path / "other.yaml"
    other.write_text(yaml.safe_dump({**SPEC, "seed": 4}))
    process = campaign(other, "--out", local)
    out, _ = process.communicate(timeout=60)
    assert process.returncode == 2 and "holds another campaign's results" in out, out
    assert "the spec's runs (robot, duration_s, runs, seed, vary or controllers) changed" in out, out
    assert len(out.strip().splitlines()) == 1, out  # the refusal before anything else: no traceback


def test_killed_part_way_and_started_again_each_run_once_with_the_uninterrupted_figures(local, spec_file, tmp_path):
    out = tmp_path / "c"
    process = campaign(spec_file, "--out", out, "--workers", 2, start_new_session=True)
    try:
        deadline = time.monotonic() + 120
        while _stored(out) < 3 and process.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        os.kill(process.pid, signal.SIGKILL)
        process.communicate(timeout=30)
    finally:
        _kill_group(process.pid)
    stored = _stored(out)
    assert 3 <= stored < RUNS, f"the kill came after {stored} of {RUNS} runs"
    said = finished(campaign(spec_file, "--out", out, "--workers", 2))
    assert f"resuming: {stored} of {RUNS} runs already" in said, said
    assert figures(out) == figures(local)


def _stored(folder: Path) -> int:
    """Runs written so far: the table's rows and the part files not folded in yet (each once)."""
    ids = set()
    for path in [folder / "results.parquet", *sorted((folder / "parts").glob("*.parquet"))]:
        try:
            ids.update(pq.read_table(path, columns=["run_id"]).column("run_id").to_pylist())
        except (FileNotFoundError, OSError):
            pass  # renamed away between the listing and the read
    return len(ids)


def _kill_group(pgid: int) -> None:
    try:
        os.killpg(pgid, signal.SIGKILL)  # the campaign's own workers, if any outlived it
    except ProcessLookupError:
        pass


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def ray_head(tmp_path):
    """A real Ray head with two CPUs on this host, started here (its own session) and ended by its process group."""
    pytest.importorskip("ray", reason="ray (a dependency, for campaigns on a cluster) is not importable here")
    port = _free_port()
    ray_bin = Path(sys.executable).with_name("ray")
    temp = Path("/tmp") / f"ray-test-{os.getpid()}"  # Ray's socket paths must stay short
    command = [str(ray_bin), "start", "--head", f"--port={port}", "--num-cpus=2", "--include-dashboard=false"]
    command += ["--disable-usage-stats", f"--temp-dir={temp}", "--block"]
    head = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while not _listening(port) and time.monotonic() < deadline:
            assert head.poll() is None, "ray start --head exited"
            time.sleep(0.2)
        yield f"127.0.0.1:{port}"
    finally:
        os.killpg(head.pid, signal.SIGTERM)
        try:
            head.wait(timeout=10)
        except subprocess.TimeoutExpired:
            pass
        _kill_group(head.pid)
        head.wait(timeout=10)


def _listening(port: int) -> bool:
    with socket.socket() as s:
        return s.connect_ex(("127.0.0.1", port)) == 0


def test_a_ray_cluster_gives_the_local_pools_rows(local, spec_file, ray_head, tmp_path):
    out = tmp_path / "c"
    said = finished(campaign(spec_file, "--out", out, "--ray", ray_head))
    assert f"Ray at {ray_head}" in said and f"{RUNS} of {RUNS} runs finished" in said, said
    assert figures(out) == figures(local)


def test_no_cluster_at_the_address_is_one_line(spec_file, tmp_path):
    pytest.importorskip("ray", reason="ray (a dependency, for campaigns on a cluster) is not importable here")
    process = campaign(spec_file, "--out", tmp_path / "c", "--ray", f"127.0.0.1:{_free_port()}")
    out, _ = process.communicate(timeout=120)
    assert process.returncode == 1 and "no Ray cluster to connect to" in out, out
    assert "Traceback" not in out


def test_two_controllers_run_on_the_same_draws_and_are_compared(spec_file, tmp_path):
    from robot_controller.experiments.campaign import campaign, report
    from robot_controller.experiments.campaign.spec import load_spec

    spec = replace(load_spec(spec_file), runs=3)
    store = campaign.run_campaign(spec, tmp_path, controllers=["lqr", "pid"], workers=1, say=lambda line: None)
    rows = {(r["controller"], r["run_id"]): r for r in store.rows}
    assert sorted(rows) == [(c, k) for c in ("lqr", "pid") for k in range(3)]
    for k in range(3):
        lqr, pid = rows["lqr", k], rows["pid", k]
        assert lqr["sensor_node.delay_s"] == pid["sensor_node.delay_s"] and lqr["seed"] == pid["seed"]
        assert lqr["tracking_rms_rad"] != pid["tracking_rms_rad"]  # another law on the same world
    text = report.write_report(spec, store.rows, tmp_path, ["lqr", "pid"]).read_text()
    assert "## Paired on the same draws" in text and "On the 3 runs both finished" in text
