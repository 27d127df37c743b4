"""A block swapped by configuration alone: sensor_node runs the second sensor block (every_other_tick) from a config
file, in the real graph, and the loop still tracks on the readings it gets (half of them), on every clock."""

import json
import subprocess
import sys

import pytest
from rosbags.rosbag2 import Reader

from tests.rostools import run_said

pytestmark = pytest.mark.ros

DURATION_S = 6.0


@pytest.mark.parametrize("clock", ["--wall-clock", "--sim-time"])
def test_the_every_other_tick_sensor_runs_in_the_graph_from_a_config_file(tmp_path, ros_domain, clock):
    """On the wall clock, and on sim time, where a tick with no reading due goes on with the latest."""
    config = tmp_path / "sensor.yaml"
    config.write_text("sensor_node:\n  ros__parameters:\n    block: every_other_tick\n")
    out = tmp_path / "run"
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", "run", clock, "--duration", str(DURATION_S)]
        + ["--config", str(config), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=150,
    )
    said = run_said(proc.stdout) + proc.stderr[-2000:]
    assert proc.returncode == 0, said
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["tracking_rms_rad"] < 0.02, said
    with Reader(out / "bag") as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
    # The encoder's 100 Hz grid, every other sample reported: 50 a second (the run's start and end trimmed).
    assert 0.6 * 50 * DURATION_S < counts["/joint_states"] < 1.2 * 50 * DURATION_S, counts
