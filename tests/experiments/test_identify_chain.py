"""``identify`` on a chain of joints, its fit and files without ROS: a user's arm simulated by MuJoCo as the run
would record it, then identify's overlay layered over the arm's files and loaded as the controller loads it."""

import json

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.model import Payload
from robot_controller.experiments import identify
from robot_controller.experiments.identify_chain import identify_chain, rounded_up
from robot_controller.parameters import consistency
from robot_controller.parameters.builders import arm_model
from tests.core.model.test_chain_identification import ARM3, record, variation


@pytest.mark.parametrize("payload", [None, Payload(0.5, (0.05, 0.02, 0.03))], ids=["no payload", "payload"])
def test_a_chains_overlay_report_and_figures(tmp_path, payload):
    (urdf := tmp_path / "arm3.urdf").write_text(ARM3)
    plant = tmp_path / "plant.yaml"
    plant_values = {"joint_friction_nm": [0.5, 0.4, 0.3], "joint_damping_nms": [0.4, 0.15, 0.004]}
    plant_values |= {"armature_kgm2": [0.02, 0.008, 0.0001], "payload": payload.as_values() if payload else []}
    cfg.write_params_file({"simulator": plant_values}, plant)
    params = cfg.load_stack("default", [plant], robot=str(urdf))
    assert identify.steps(params) == 8  # the run, the fit, three joints, the payload, the files, the lag

    controller_urdf = resources.resolve_urdf(params["pid_controller"]["urdf_path"])
    time_s, q, v, tau, limit = record(controller_urdf, variation(payload))
    facts = {"duration_s": 20.0, "seed": 0, "start_hz": 0.1, "end_hz": 0.5, "amplitude_rad": [0.4, 0.4, 0.4]}
    said: list[str] = []
    left_out = {"effort_limit": limit, "braked": np.zeros(q.shape, bool)}
    results = identify_chain(params, tmp_path, (time_s, q, v, tau), left_out, facts, said.append)

    overlay = cfg.read_params_file(tmp_path / "identified.yaml")["pid_controller"]
    assert set(overlay) == {"model_inertia", "model_damping", "model_coulomb_friction", "model_payload"}
    np.testing.assert_allclose(overlay["model_coulomb_friction"], [0.5, 0.4, 0.3], atol=0.05)
    np.testing.assert_allclose(overlay["model_damping"], [0.6, 0.23, 0.006], rtol=0.2)
    if payload is None:
        assert overlay["model_payload"] == [0.0, 0.0, 0.0, 0.0] and results["payload_found"] is False
    else:
        np.testing.assert_allclose(overlay["model_payload"], payload.as_values(), atol=0.01)
    # Layered over the arm's files it loads, and the controller's model carries the armature identified.
    layered = cfg.load_stack("default", [plant, tmp_path / "identified.yaml"], robot=str(urdf))
    consistency.check_stack(layered)
    model = arm_model(layered["pid_controller"])
    np.testing.assert_allclose(model.model.dof_armature[:3], [0.02, 0.008, 0.0001], rtol=0.2)
    np.testing.assert_allclose(model.damping[:3], overlay["model_damping"])

    written = json.loads((tmp_path / "identification.json").read_text())
    for joint in ("shoulder", "elbow", "wrist"):
        for name, unit in [("coulomb_friction", "nm"), ("damping", "nm_s_per_rad"), ("inertia", "kg_m2")]:
            assert written[f"{joint}_{name}_{unit}"] > 0 and f"{joint}_{name}_stderr_{unit}" in written, name
        assert written[f"{joint}_armature_kg_m2"] > 0 and f"{joint}_armature_stderr_kg_m2" in written
        assert written[f"{joint}_identified"] and written[f"{joint}_samples"] > 300
    assert written["wrist_urdf_damping_nm_s_per_rad"] == pytest.approx(0.002)
    assert written["payload_found"] is (payload is not None)

    report = (tmp_path / "identification.md").read_text()
    assert "| shoulder | damping [N·m·s/rad] | 0.6" in report or "| shoulder | damping [N·m·s/rad] | 0.59" in report
    assert "| 0.2 | 3.00 |" in report  # the URDF's value beside it, and the ratio
    assert "What it cannot identify" in report and "other links' masses" in report
    assert [line.split(":")[1].strip() for line in said[:3]] == ["shoulder", "elbow", "wrist"]
    assert ("payload 0.500 kg" if payload else "no payload found") in said[3]


def test_an_inertia_is_rounded_up_never_below_the_links_own():
    assert rounded_up(0.3026251) == 0.302626
    assert rounded_up(0.0002) == 0.0002
    assert rounded_up(1.23456789) == 1.23457
