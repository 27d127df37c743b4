"""One run of a campaign replayed through the real ROS graph on sim time: the run's draws and noise seed reach the
nodes, and the graph's tracking is the campaign's (in-process) within 5 %."""

import json
import subprocess
import sys

import pyarrow.parquet as pq
import pytest
import yaml

from tests.rostools import run_said

pytestmark = pytest.mark.ros

SPEC = {
    "robot": "one_dof",
    "duration_s": 6,
    "runs": 2,
    "seed": 11,
    "vary": {
        "sensor_node.delay_s": {"uniform": [0.005, 0.025]},
        "sensor_node.position_noise_std": {"loguniform": [0.002, 0.01]},
        "motor_node.lag_time_constant_s": {"uniform": [0.0, 0.01]},
    },
}


def cli(*args, timeout=240, codes=(0,)):
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", *map(str, args)], capture_output=True, text=True, timeout=timeout
    )
    assert proc.returncode in codes, run_said(proc.stdout) + proc.stderr[-2000:]
    return proc.stdout


def test_a_replayed_run_has_its_draws_and_the_campaigns_figures(tmp_path, ros_domain):
    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump(SPEC))
    cli("campaign", spec, "--out", tmp_path / "c", "--workers", 1)
    row = next(r for r in pq.read_table(tmp_path / "c" / "results.parquet").to_pylist() if r["run_id"] == 1)
    # A world the controller does not know may start beyond the band: the replayed run then says FAILED, exit 1.
    said = cli("campaign", "replay", tmp_path / "c", 1, "--out", tmp_path / "r", codes=(0, 1))
    assert "the campaign's (in process) beside the graph's (sim time)" in said, said
    ran = yaml.safe_load((tmp_path / "r" / "params.yaml").read_text())
    sensor = ran["sensor_node"]["ros__parameters"]
    assert sensor["delay_s"] == pytest.approx(row["sensor_node.delay_s"])
    assert sensor["position_noise_std"] == pytest.approx(row["sensor_node.position_noise_std"])
    assert sensor["seed"] == row["seed"]
    assert ran["motor_node"]["ros__parameters"]["lag_time_constant_s"] == pytest.approx(
        row["motor_node.lag_time_constant_s"]
    )
    metrics = json.loads((tmp_path / "r" / "metrics.json").read_text())
    assert metrics["clock"] == "sim_lockstep" and metrics["seed"] == row["seed"]
    assert metrics["tracking_rms_rad"] == pytest.approx(row["tracking_rms_rad"], rel=0.05)
    assert metrics["tracking_max_rad"] == pytest.approx(row["tracking_max_rad"], rel=0.05)
    assert metrics["start_tracking_max_rad"] == pytest.approx(row["start_tracking_max_rad"], rel=0.05)
    assert ("FAILED: " in said) == (metrics["verdict"] == "failed"), said


def test_replay_of_a_run_the_campaign_does_not_hold_is_one_line(tmp_path):
    spec = tmp_path / "spec.yaml"
    spec.write_text(yaml.safe_dump({**SPEC, "runs": 1, "duration_s": 3}))
    cli("campaign", spec, "--out", tmp_path / "c", "--workers", 1)
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "robot_controller.cli",
            "campaign",
            "replay",
            tmp_path / "c",
            "5",
            "--out",
            tmp_path / "r",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 2 and "RUN_ID 5: the campaign's runs are 0 to 0" in proc.stderr, proc.stderr
    assert not (tmp_path / "r").exists()


def test_a_replayed_run_of_an_identified_world_runs_with_what_was_found(tmp_path, ros_domain):
    """With ``identify: true``, the replay finds the world's model again (the drive's lag among it) and the graph runs
    with it: the campaign's figures."""
    spec = tmp_path / "spec.yaml"
    lag = {"motor_node.lag_time_constant_s": {"uniform": [0.01, 0.02]}}
    lagged = {**SPEC, "runs": 1, "identify": True, "vary": lag}
    spec.write_text(yaml.safe_dump(lagged))
    cli("campaign", spec, "--out", tmp_path / "c", "--workers", 1)
    row = pq.read_table(tmp_path / "c" / "results.parquet").to_pylist()[0]
    said = cli("campaign", "replay", tmp_path / "c", 0, "--out", tmp_path / "r")
    controller = yaml.safe_load((tmp_path / "r" / "params.yaml").read_text())["pid_controller"]["ros__parameters"]
    assert controller["model_drive_lag_s"] == pytest.approx(row["identified_drive_lag_s"])
    assert controller["model_drive_lag_s"] == pytest.approx(row["motor_node.lag_time_constant_s"], rel=0.01)
    metrics = json.loads((tmp_path / "r" / "metrics.json").read_text())
    assert metrics["tracking_rms_rad"] == pytest.approx(row["tracking_rms_rad"], rel=1e-3), said
