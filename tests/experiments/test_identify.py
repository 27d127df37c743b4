"""Identification through the real graph (lockstep): the heavy test arm under a
controller that believes the reference URDF, identified, and the overlay it
writes loaded and checked like any configuration."""

import json
import subprocess
import sys

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
    assert set(identified["pid_controller"]) == set(MODEL_KEYS)
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
