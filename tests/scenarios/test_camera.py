"""Encoders swapped for a camera, through the real graph on sim time (``run --sensing``): the one joint tracks through
rendered frames, a hidden marker's joint runs on the model and says so, the Panda tracks, the camera beside the
encoder is no worse than the encoder alone, a slower camera moved elsewhere still tracks, and one that sees nothing is
refused before anything starts."""

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from rosbags.rosbag2 import Reader

from robot_controller.blocks import spec

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[2]


def run(tmp_path: Path, name: str, *args: str, config: str = "", duration: str = "6"):
    """``robot-controller run --sim-time`` with ``args`` and a parameter file holding ``config``."""
    command = [sys.executable, "-m", "robot_controller.cli", "run", "--sim-time", "--duration", duration, *args]
    if config:
        path = tmp_path / f"{name}.yaml"
        path.write_text(config)
        command += ["--config", str(path)]
    out = tmp_path / name
    proc = subprocess.run(command + ["--out", str(out)], capture_output=True, text=True, timeout=300, cwd=ROOT)
    metrics_file = out / "metrics.json"
    metrics = json.loads(metrics_file.read_text()) if metrics_file.exists() else None
    return proc, out, metrics


def said(proc: subprocess.CompletedProcess) -> str:
    return (proc.stdout + proc.stderr)[-4000:]


def test_the_one_joint_tracks_through_a_camera_and_the_bag_keeps_its_images_small(tmp_path, ros_domain):
    proc, out, metrics = run(tmp_path, "camera", "--sensing", "camera")
    assert proc.returncode == 0, said(proc)
    assert metrics["tracking_rms_rad"] <= 0.005, metrics  # the tutorial's figure, with a camera for the encoder
    assert metrics["sensing"] == "camera" and metrics["camera_frames_lost"] == 0, metrics
    assert metrics["camera_rate_hz"] == pytest.approx(100 / 3, rel=0.01), metrics  # every 3rd of the world's states
    assert "sensing      a camera at 33.3 Hz" in proc.stdout, said(proc)
    with Reader(out / "bag") as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
    assert spec.IMAGE.topic not in counts and counts[spec.DETECTIONS.topic] >= 5 * 6 - 2, counts  # 5 a second, JPEG
    bag_bytes = sum(f.stat().st_size for f in (out / "bag").iterdir())
    assert bag_bytes < 100e6 * 6 / 60, bag_bytes  # a 60 s run's within 100 MB


def test_a_hidden_marker_runs_its_joint_on_the_model_said_once_and_the_arm_stays_in_its_band(tmp_path, ros_domain):
    hidden = "camera_node:\n  ros__parameters:\n    occluded_link: link1\n    occlusion_s: [2.5, 2.0]\n"
    proc, _, metrics = run(tmp_path, "hidden", "--sensing", "camera", config=hidden)
    assert proc.returncode == 0, said(proc)
    assert proc.stdout.count("joint1: no marker in the camera's view constrains it") == 1, said(proc)
    again = re.search(r"joint1: seen again after ([0-9.]+) s on the arm's model", proc.stdout)
    assert again and float(again.group(1)) == pytest.approx(2.0, abs=0.05), said(proc)  # to the frame (30 ms)
    assert metrics["camera_unseen_s"]["joint1"] == pytest.approx(2.0, abs=0.05), metrics
    assert "on the arm's model for want of a marker: joint1 " in proc.stdout, said(proc)
    assert metrics["tracking_max_rad"] <= 0.02, metrics


def test_the_panda_tracks_through_a_camera(tmp_path, ros_domain):
    proc, _, metrics = run(tmp_path, "panda", "--robot", "panda", "--sensing", "camera", duration="5")
    assert proc.returncode == 0, said(proc)
    assert max(metrics["tracking_rms_rad_per_joint"]) <= 0.02, metrics


def test_the_camera_beside_the_encoder_is_no_worse_than_the_encoder_alone(tmp_path, ros_domain):
    alone, _, encoder = run(tmp_path, "encoders")
    proc, _, both = run(tmp_path, "both", "--sensing", "both")
    assert alone.returncode == 0 and proc.returncode == 0, said(alone) + said(proc)
    assert both["camera_frames"] > 0 and "encoders and a camera fused" in proc.stdout, said(proc)
    assert "dropped" not in proc.stdout + proc.stderr, said(proc)  # every frame in time: the world waited for it
    assert both["tracking_rms_rad"] <= encoder["tracking_rms_rad"], (both, encoder)


def test_a_camera_moved_and_slowed_to_15_hz_still_tracks(tmp_path, ros_domain):
    moved = (
        "camera_node:\n  ros__parameters:\n    camera_rate_hz: 15.0\n"
        "    camera_position_m: [0.8, -2.0, 1.6]\n    camera_target_m: [0.0, 0.0, 1.0]\n"
    )
    proc, _, metrics = run(tmp_path, "moved", "--sensing", "camera", config=moved)
    assert proc.returncode == 0, said(proc)
    assert metrics["camera_rate_hz"] == pytest.approx(100 / 7, rel=0.01), metrics
    assert metrics["tracking_max_rad"] <= 0.02, metrics


def test_a_camera_that_sees_no_marker_is_refused_before_anything_starts(tmp_path, ros_domain):
    away = (
        "camera_node:\n  ros__parameters:\n"
        "    camera_position_m: [0.0, -1.5, 1.0]\n    camera_target_m: [0.0, -3.0, 1.0]\n"
    )
    proc, out, _ = run(tmp_path, "away", "--sensing", "camera", config=away)
    assert proc.returncode == 2, said(proc)
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "the camera does not see joint1" in lines[0], proc.stderr
    assert "camera_position_m [0, -1.5, 1]" in lines[0] and not out.exists(), proc.stderr
