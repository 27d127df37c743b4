"""Multi-joint robots through the real graph in lockstep: the planar arm and
the Panda track every joint, each torque within its joint's URDF limit."""

import json
import subprocess
import sys

import pytest

from tests.rostools import run_said

pytestmark = pytest.mark.ros


def lockstep_run(out, robot: str, duration: str, *extra: str) -> dict:
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "robot_controller.cli",
            "run",
            "--robot",
            robot,
            "--sim-time",
            "--duration",
            duration,
            "--out",
            str(out),
            *extra,
        ],
        capture_output=True,
        text=True,
        timeout=240,
    )
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]
    return json.loads((out / "metrics.json").read_text())


def test_the_planar_arm_tracks_every_joint_within_a_milliradian(tmp_path, ros_domain):
    metrics = lockstep_run(tmp_path / "planar2", "planar2", "8")
    assert metrics["joint_names"] == ["shoulder", "elbow"]
    assert metrics["robot"] == "planar2"
    assert max(metrics["tracking_rms_rad_per_joint"]) == metrics["tracking_rms_rad"]
    assert all(rms < 0.0012 for rms in metrics["tracking_rms_rad_per_joint"]), metrics["tracking_rms_rad_per_joint"]
    peaks = metrics["peak_torque_nm_per_joint"]
    assert peaks[0] < 30.0 and peaks[1] < 10.0  # the URDF's effort limits
    assert peaks[0] > 10.0  # the shoulder carries the elbow: gravity alone needs more than the reference arm's 10


def test_the_panda_tracks_its_seven_joints(tmp_path, ros_domain):
    metrics = lockstep_run(tmp_path / "panda", "panda", "5")
    assert len(metrics["joint_names"]) == 7 and metrics["joint_names"][0] == "panda_joint1"
    assert metrics["watchdog_ticks"] == 0 and metrics["saturated_ticks"] == 0
    assert all(rms < 0.002 for rms in metrics["tracking_rms_rad_per_joint"]), metrics["tracking_rms_rad_per_joint"]
    limits = [87.0] * 4 + [12.0] * 3
    assert all(peak < limit for peak, limit in zip(metrics["peak_torque_nm_per_joint"], limits, strict=True))
    assert metrics["peak_torque_nm_per_joint"][3] > 15.0  # joint 4 holds the arm up at the ready pose


def test_a_panda_that_loses_its_sensor_for_two_seconds_is_braked_within_its_band(tmp_path, ros_domain):
    """Without readings a chain of joints stops on its model only briefly (the
    open-loop model drifts: gravity makes it unstable), then the brakes hold it."""
    from robot_controller import parameters as cfg
    from robot_controller.experiments import faults

    case = faults.Case("sensor_node", 2.0)
    # On the wall clock: the controller's own watchdog stops on the model (the paced world brakes at once).
    entry = faults.run_case(case, tmp_path / case.name, cfg.load_stack(robot="panda"), wall_clock=True)
    assert entry["exit_code"] == 0 and "failure" not in entry, entry
    assert entry["brake_engaged"], entry
    assert max(entry["max_deviation_rad_per_joint"]) <= 0.1, entry  # every joint inside the band it sweeps
    assert entry["reacquire_s"] == entry["reacquire_s"], entry  # back on the trajectory before the run ended
