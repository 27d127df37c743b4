"""``tune`` on a chain of joints: each joint's LQR torque weight designed for a target against its own delay margin
and noise torque, and any design verified against the gains in force over seeds on the real graph, written to use
only when it beats them past its spread."""

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from robot_controller import cli
from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError
from robot_controller.experiments.autotune import chain
from robot_controller.experiments.autotune.verification import Verification
from robot_controller.parameters.builders import arm_model

ARM = Path(__file__).resolve().parents[3] / "examples" / "light_wrist_arm.urdf"


def test_each_joint_gets_its_own_weight_within_its_margin_and_noise():
    params = cfg.load_stack("default", None, str(ARM))
    tracking = chain.design_joints(params, "tracking")
    robust = chain.design_joints(params, "robust")
    assert [d.name for d in tracking] == ["shoulder", "elbow", "wrist"]
    for fast, safe in zip(tracking, robust, strict=True):
        assert fast.found and safe.found
        assert fast.delay_margin_periods >= 2 and safe.delay_margin_periods >= 4
        assert fast.noise_torque_nm <= 0.05 * fast.torque_limit_nm
        assert safe.lqr_r > fast.lqr_r and safe.kp < fast.kp  # a wider margin costs bandwidth
    # The fastest weight that keeps the margin: a quarter decade faster loses it.
    faster = chain._joint_figures(
        cfg.controller_config(params["pid_controller"], 3),
        arm_model(params["pid_controller"]),
        3,
        np.array([d.in_force_r for d in tracking]),
        2,
        tracking[2].lqr_r / 10**0.25,
        np.array([0.005, 0.02]),
    )
    assert faster[2] < 2 or faster[3] > 0.05 * tracking[2].torque_limit_nm
    overlay = chain.overlay(tracking)
    assert overlay["controller_type"] == "lqr" and len(overlay["lqr_r"]) == 3
    tuned = cfg.merge(params, {"pid_controller": overlay})
    assert cfg.controller_config(tuned["pid_controller"], 3).lqr_r == tuple(overlay["lqr_r"])
    with pytest.raises(ConfigError, match="--target fastest"):
        chain.design_joints(params, "fastest")


@pytest.mark.parametrize(
    ("before", "after", "ok", "recommended"),
    [
        ((1.0e-3, 1.1e-3, 0.9e-3), (0.5e-3, 0.6e-3, 0.45e-3), True, True),  # better on every seed
        ((0.370e-3, 0.372e-3, 0.368e-3), (0.374e-3, 0.369e-3, 0.371e-3), True, False),  # within its spread
        ((1.0e-3, 1.1e-3, 0.9e-3), (0.5e-3, 0.6e-3, 0.45e-3), False, False),  # a run of it failed
        ((1.0e-3, 1.0e-3, 1.0e-3), (1.1e-3, 1.1e-3, 1.1e-3), True, False),  # worse
    ],
)
def test_a_design_is_recommended_only_past_twice_its_standard_error(before, after, ok, recommended):
    checked = Verification((0, 1, 2), before, after, ok, 6.0)
    assert checked.recommended is recommended
    assert ("recommended" in checked.verdict()) and (("not recommended" in checked.verdict()) is not recommended)
    assert checked.as_values()["recommended"] == int(recommended)


def test_a_design_that_is_the_configuration_in_force_is_not_run_and_not_advice(tmp_path):
    from robot_controller.experiments.autotune.verification import verify

    params = cfg.load_stack("default")
    checked = verify(params, cfg.merge(params, {}), seeds=(0, 1, 2), duration_s=6.0, out=tmp_path, progress=print)
    assert checked.unchanged and not checked.recommended and not any(tmp_path.iterdir())
    assert "the design is the configuration in force" in checked.verdict()
    panda = cfg.load_stack("default", None, "panda")
    designs = chain.design_joints(panda, "tracking")  # the Panda's default: each joint at its fastest already
    assert chain.in_force(panda, designs)
    light = cfg.load_stack("default", None, str(ARM))
    assert not chain.in_force(light, chain.design_joints(light, "tracking"))  # its elbow and wrist go faster


@pytest.mark.ros
def test_tune_on_a_chain_designs_every_joint_and_writes_it_only_if_it_is_better(tmp_path, ros_domain, capfd):
    out = tmp_path / "tune"
    assert cli.main(["tune", "--robot", str(ARM), "--quick", "--out", str(out)]) == 0
    said = capfd.readouterr().out
    values = json.loads((out / "tune.json").read_text())
    assert values["joint_count"] == 3 and values["verification_verified_seeds"] == 3
    for joint in ("shoulder", "elbow", "wrist"):
        assert values[f"{joint}_delay_margin_periods"] >= 2
    report = (out / "report.md").read_text()
    assert "## Verified on the real graph" in report and "wrist: lqr_r" in report
    if values["verification_recommended"]:
        tuned = yaml.safe_load((out / "tuned.yaml").read_text())["pid_controller"]["ros__parameters"]
        assert tuned["lqr_r"] == [values[f"{j}_lqr_r"] for j in ("shoulder", "elbow", "wrist")]
        assert f"use it with --config {out / 'tuned.yaml'}" in said
    else:
        assert not (out / "tuned.yaml").exists()
        assert "nothing better than the gains in force was found: nothing written to use" in said
