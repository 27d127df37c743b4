"""The inertia adaptation seen from outside, through the real graph (the launcher, sim-time lockstep): the one-joint
arm with a rotor its controller does not know learns it, says its gain changes in the log, and ``metrics.json`` holds
the armature learnt at the end."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robot_controller.core.controller import state_layout
from robot_controller.scoring.bag_reader import read_recording
from tests.rostools import run_said

pytestmark = pytest.mark.ros

ROOT = Path(__file__).resolve().parents[3]
ARMATURE_KGM2 = 0.1  # the simulator's rotor on the reference arm's joint (its own inertia: 1/12 kg·m²)
OWN_KGM2 = 1.0 / 12.0


def test_a_rotor_the_controller_does_not_know_is_learnt_said_and_in_metrics_json(tmp_path, ros_domain):
    config = tmp_path / "rotor.yaml"
    config.write_text(f"simulator:\n  ros__parameters:\n    armature_kgm2: [{ARMATURE_KGM2}]\n")
    out = tmp_path / "run"
    # The start, on gains for the lighter joint, swings 31 mrad before the adaptation has learnt: a band that allows it.
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", "run", "--sim-time", "--duration", "5"]
        + ["--config", str(config), "--out", str(out), "--tracking-band", "0.05"],
        capture_output=True,
        text=True,
        timeout=180,
        cwd=ROOT,
    )
    said = proc.stdout + proc.stderr
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]
    learnt = json.loads((out / "metrics.json").read_text())["adapted_armature_kgm2"]
    # Learnt towards the rotor (0.064 in 5 s on an unloaded host; ADAPT_S sets the pace), never beyond the bound.
    assert len(learnt) == 1 and 0.3 * ARMATURE_KGM2 < learnt[0] < min(1.5 * ARMATURE_KGM2, 20 * OWN_KGM2), learnt
    notes = [line for line in said.splitlines() if "[pid_controller] [INFO] inertia adaptation: gains in force" in line]
    assert notes and "joint1 ×" in notes[-1], said[-3000:]
    # Every tick carries the armature as it stood; metrics.json's is the one at the end of the scored run (the bag
    # runs on a little past it).
    recording = read_recording(out / "bag")
    armature = recording.law_terms[state_layout.ADAPTED_ARMATURE][:, 0]
    assert len(armature) == len(recording.state["time_s"]) and np.all(np.isfinite(armature)) and armature[0] == 0.0
    assert learnt[0] in armature.tolist() and np.max(armature) <= 20 * OWN_KGM2
