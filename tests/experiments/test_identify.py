"""Identification through the real graph (lockstep): the heavy test arm under a
controller that believes the reference URDF, identified, and the overlay it
writes loaded and checked like any configuration."""

import json
import subprocess
import sys

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.model import PARAMETERS, ArmDynamics, JointArmModel
from robot_controller.experiments import inprocess
from robot_controller.parameters import consistency
from robot_controller.parameters.builders import MODEL_KEYS, arm_model
from tests.rostools import run_said

pytestmark = pytest.mark.ros

HEAVY_URDF = resources.share_dir() / "description" / "heavy_arm.urdf"
DURATION_S = 10.0


def test_identify_recovers_the_heavy_arm_through_the_graph(tmp_path, ros_domain):
    heavy = tmp_path / "heavy.yaml"
    cfg.write_params_file(
        {"simulator": {"urdf_path": str(HEAVY_URDF)}, "motor_node": {"urdf_path": str(HEAVY_URDF)}}, heavy
    )
    out = tmp_path / "identify"
    code = (
        "from pathlib import Path; from robot_controller import parameters as cfg; "
        "from robot_controller.experiments.identify import identify; "
        f"identify(cfg.load_stack('default', [{str(heavy)!r}]), Path({str(out)!r}), "
        f"duration_s={DURATION_S}, seed=1)"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=180)
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]

    # The overlay holds the controller's model values and nothing else.
    overlay = out / "identified.yaml"
    identified = cfg.read_params_file(overlay)
    assert set(identified) == {"pid_controller"}
    assert set(identified["pid_controller"]) == {*MODEL_KEYS, "model_drive_lag_s"}
    assert identified["pid_controller"]["model_drive_lag_s"] == 0.0  # the default drive has none
    # ... within 10 % of the heavy arm's truth, as MuJoCo computes it from its URDF.
    true = JointArmModel.over_urdf(ArmDynamics(HEAVY_URDF))
    for key, name in zip(MODEL_KEYS, PARAMETERS, strict=True):
        expected = float(getattr(true, name)[0])
        assert identified["pid_controller"][key][0] == pytest.approx(expected, rel=0.10), key

    results = json.loads((out / "identification.json").read_text())
    for name in PARAMETERS:
        assert any(k.startswith(f"joint1_{name}_stderr") for k in results), name
    assert results["joint1_samples"] > 500 and results["joint1_residual_rms_nm"] < 0.1
    assert "| joint1 | inertia" in (out / "identification.md").read_text()

    # Layered over the arm's file, it loads and passes the whole-configuration check.
    params = cfg.load_stack("default", [heavy, overlay])
    consistency.check_stack(params)
    assert isinstance(arm_model(params["pid_controller"]), JointArmModel)

    # And the controller that uses it tracks the heavy arm (in-process, for speed).
    wrong = inprocess.simulate(cfg.load_stack("default", [heavy]), duration_s=8.0, seed=3).tracking_metrics()
    right = inprocess.simulate(params, duration_s=8.0, seed=3).tracking_metrics()
    assert right["tracking_rms_rad"] <= 0.003
    assert wrong["tracking_rms_rad"] > 10 * right["tracking_rms_rad"]


def test_identify_recovers_each_joint_and_the_payload_of_a_chain_through_the_graph(tmp_path, ros_domain):
    """planar2 with friction, damping and rotor inertia its URDF lacks, a payload and a drive of 15 ms lag: each
    joint within the promise (friction ±0.05 N·m, damping and armature ±20 %), the payload and the lag found, the
    overlay loadable."""
    friction, added_damping, armature = [0.5, 0.3], [0.3, 0.1], [0.05, 0.01]
    plant = tmp_path / "plant.yaml"
    values = {"joint_friction_nm": friction, "joint_damping_nms": added_damping, "armature_kgm2": armature}
    world = {"simulator": {**values, "payload": [0.8, 0.05, 0.0, 0.1]}, "motor_node": {"lag_time_constant_s": 0.015}}
    cfg.write_params_file(world, plant)
    out = tmp_path / "identify"
    code = (
        "from pathlib import Path; from robot_controller import parameters as cfg; "
        "from robot_controller.experiments.identify import identify; "
        f"identify(cfg.load_stack('default', [{str(plant)!r}], robot='planar2'), Path({str(out)!r}), "
        f"duration_s={DURATION_S}, seed=1)"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, run_said(proc.stdout) + proc.stderr[-2000:]

    overlay = out / "identified.yaml"
    identified = cfg.read_params_file(overlay)["pid_controller"]
    keys = {"model_inertia", "model_damping", "model_coulomb_friction", "model_payload", "model_drive_lag_s"}
    assert set(identified) == keys
    assert identified["model_drive_lag_s"] == pytest.approx(0.015, rel=1e-3)
    results = json.loads((out / "identification.json").read_text())
    urdf = ArmDynamics(resources.resolve_urdf(cfg.load_stack(robot="planar2")["simulator"]["urdf_path"]))
    for j, joint in enumerate(("shoulder", "elbow")):
        assert results[f"{joint}_coulomb_friction_nm"] == pytest.approx(friction[j], abs=0.05), joint
        total = urdf.damping[j] + added_damping[j]
        assert results[f"{joint}_damping_nm_s_per_rad"] == pytest.approx(total, rel=0.2), joint
        assert results[f"{joint}_armature_kg_m2"] == pytest.approx(armature[j], rel=0.2), joint
    assert results["payload_found"] and results["payload_mass_kg"] == pytest.approx(0.8, rel=0.02)
    assert results["payload_unidentifiable"] == ["y_m"]  # both axes along it
    assert identified["model_payload"] == pytest.approx([0.8, 0.05, 0.0, 0.1], abs=0.01)

    params = cfg.load_stack("default", [plant, overlay], robot="planar2")
    consistency.check_stack(params)
    np.testing.assert_allclose(arm_model(params["pid_controller"]).model.dof_armature[:2], armature, rtol=0.2)
