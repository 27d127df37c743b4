"""A light arm with friction its URDF lacks, as a user meets it: the default controller leaves its 0.0002 kg·m² wrist
stuck and slipping far outside its band; ``identify`` finds the friction, damping and rotor inertia, and with the
overlay it writes every joint tracks within 2 mrad RMS (real CLI, DDS, MuJoCo; sim time)."""

import json
import subprocess
import sys
from pathlib import Path

import pytest

from robot_controller import parameters as cfg
from tests.rostools import run_said

pytestmark = pytest.mark.ros

ARM = Path(__file__).resolve().parents[2] / "examples" / "light_wrist_arm.urdf"
PLANT = {
    "joint_friction_nm": [0.5, 0.4, 0.3],
    "joint_damping_nms": [0.4, 0.15, 0.004],
    "armature_kgm2": [0.02, 0.008, 0.0001],
}


def cli(*args: str) -> subprocess.CompletedProcess:
    command = [sys.executable, "-m", "robot_controller.cli", *args]
    return subprocess.run(command, capture_output=True, text=True, timeout=300)


def test_identified_friction_brings_a_light_wrist_into_its_band(tmp_path, ros_domain):
    plant = tmp_path / "plant.yaml"
    cfg.write_params_file({"simulator": PLANT}, plant)
    stack = ["--robot", str(ARM), "--config", str(plant)]
    unknown = cli("run", *stack, "--sim-time", "--duration", "8", "--out", str(tmp_path / "unknown"))
    assert unknown.returncode == 1, run_said(unknown.stdout + unknown.stderr)  # far outside its band
    said = cli("identify", *stack, "--out", str(tmp_path / "id"))
    assert said.returncode == 0, run_said(said.stdout + said.stderr)
    found = json.loads((tmp_path / "id" / "identification.json").read_text())
    for j, joint in enumerate(("shoulder", "elbow", "wrist")):
        assert found[f"{joint}_coulomb_friction_nm"] == pytest.approx(PLANT["joint_friction_nm"][j], abs=0.05)
    identified = tmp_path / "id" / "identified.yaml"
    with_it = [*stack, "--config", str(identified)]
    known = cli("run", *with_it, "--sim-time", "--duration", "8", "--out", str(tmp_path / "k"))
    assert known.returncode == 0, run_said(known.stdout + known.stderr)
    metrics = json.loads((tmp_path / "k" / "metrics.json").read_text())
    before = json.loads((tmp_path / "unknown" / "metrics.json").read_text())
    assert before["tracking_rms_rad"] > 0.05
    assert metrics["tracking_rms_rad"] <= 0.002, metrics["tracking_rms_rad"]  # the worst joint
