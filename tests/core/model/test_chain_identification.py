"""Identification of a chain of joints (no ROS): a user's 3-joint arm simulated by MuJoCo with friction, damping and
rotor inertia its URDF lacks (and a payload), driven through a chirp, fitted back from the true state and the applied
torque. The tolerances are the ones a user is promised: friction within 0.05 N·m, damping and armature within 20 %."""

from pathlib import Path

import numpy as np
import pytest

from robot_controller.core.model import ArmDynamics, MujocoPlant, Payload, PlantVariation, fit_chain
from robot_controller.core.reference import Chirp

# A user's arm: shoulder and elbow about -y (gravity on both), a continuous wrist about x with a light hand.
ARM3_PATH = Path(__file__).resolve().parents[3] / "examples" / "light_wrist_arm.urdf"
ARM3 = ARM3_PATH.read_text()
URDF_DAMPING = np.array([0.2, 0.08, 0.002])  # N·m·s/rad, the URDF's own
FRICTION_NM = (0.5, 0.4, 0.3)
DAMPING_NMS = (0.4, 0.15, 0.004)  # added to the URDF's
ARMATURE_KGM2 = (0.02, 0.008, 0.0001)
PERIOD_S = 0.01
DURATION_S = 20.0


@pytest.fixture(scope="module")
def arm3():
    return ARM3_PATH


@pytest.fixture(scope="module")
def nominal(arm3):
    """The arm with the friction, damping and armature its URDF lacks, no payload."""
    return record(arm3, variation())


def record(urdf, variation: PlantVariation, amplitude=(0.4, 0.4, 0.4), duration_s: float = DURATION_S):
    """The arm under ``variation`` following a chirp (0.1 → 0.5 Hz, as identify's) under a PD with a model
    feedforward 10 % short of the plant's friction, damping and armature, the torque held over each 10 ms:
    ``(time, position, velocity, torque, effort limit)``, row k's torque the one that acted from sample k-1 to k."""
    plant = MujocoPlant(urdf, 0.001, variation=variation)
    n = plant.joint_count
    plant.reset(np.zeros(n))
    model = ArmDynamics(urdf)
    armature = 0.9 * np.asarray(variation.armature_kgm2)
    damping, friction = 0.9 * np.asarray(variation.joint_damping_nms), 0.9 * np.asarray(variation.joint_friction_nm)
    inertia = np.diag(model.mass_matrix(np.zeros(n))) + armature
    chirp = Chirp(np.array(amplitude, dtype=float), 0.1, 0.5, duration_s, np.zeros(n))
    rows = [(0.0, np.zeros(n), np.zeros(n), np.zeros(n))]
    for k in range(int(round(duration_s / PERIOD_S))):
        q_ref, v_ref, a_ref = chirp.sample(k * PERIOD_S)
        q, v = plant.state()
        feedforward = model.torque(q_ref, v_ref, a_ref) + armature * a_ref + damping * v_ref + friction * np.sign(v_ref)
        torque = feedforward + inertia * (400.0 * (q_ref - q) + 40.0 * (v_ref - v))
        plant.step(np.clip(torque, -plant.effort_limit, plant.effort_limit), int(round(PERIOD_S / plant.physics_dt)))
        q, v = plant.state()
        rows.append((plant.time_s, q, v, plant.applied_torque.copy()))
    time_s, q, v, tau = (np.array(column) for column in zip(*rows, strict=True))
    return time_s, q, v, tau, plant.effort_limit


def variation(payload: Payload | None = None, **changes) -> PlantVariation:
    values = dict(joint_friction_nm=FRICTION_NM, joint_damping_nms=DAMPING_NMS, armature_kgm2=ARMATURE_KGM2)
    return PlantVariation(**{**values, **changes}, payload=payload)


def assert_recovers(joint, j: int) -> None:
    """Within the promise: friction ±0.05 N·m, damping (the URDF's plus the added) and armature ±20 %."""
    assert joint.identified, joint.reason
    assert joint.coulomb_friction == pytest.approx(FRICTION_NM[j], abs=0.05), joint.name
    assert joint.damping == pytest.approx(URDF_DAMPING[j] + DAMPING_NMS[j], rel=0.2), joint.name
    assert joint.armature == pytest.approx(ARMATURE_KGM2[j], rel=0.2), joint.name
    for name in ("armature", "damping", "coulomb_friction"):
        assert 0 < getattr(joint, f"{name}_stderr") < 0.05 * getattr(joint, name), (joint.name, name)
    assert joint.samples > 300 and joint.clipped == ()


def test_recovers_each_joints_friction_damping_and_armature(arm3, nominal):
    time_s, q, v, tau, limit = nominal
    fit = fit_chain(arm3, time_s, q, v, tau, effort_limit=limit)
    assert [joint.name for joint in fit.joints] == ["shoulder", "elbow", "wrist"]
    for j, joint in enumerate(fit.joints):
        assert_recovers(joint, j)
        assert joint.inertia == pytest.approx(joint.urdf_inertia + joint.armature)  # M(0)'s diagonal plus armature
        assert joint.urdf_damping == pytest.approx(URDF_DAMPING[j]) and joint.urdf_coulomb_friction == 0.0
    assert not fit.payload_found
    # The joints' values are those fitted with no payload: the residual is the one without.
    assert fit.residual_rms_nm == pytest.approx(fit.residual_rms_without_payload_nm)
    assert fit.residual_rms_nm < 0.02 * fit.residual_rms_urdf_nm


def test_finds_a_payload_together_with_the_joints(arm3):
    truth = Payload(0.5, (0.05, 0.02, 0.03))
    time_s, q, v, tau, limit = record(arm3, variation(truth))
    fit = fit_chain(arm3, time_s, q, v, tau, effort_limit=limit)
    assert fit.payload_found and fit.payload.unidentifiable == ()
    assert fit.payload.payload.mass_kg == pytest.approx(0.5, rel=0.02)
    np.testing.assert_allclose(fit.payload.payload.com_m, truth.com_m, atol=0.005)
    with_payload = np.diag(ArmDynamics(arm3, fit.payload.payload).mass_matrix(np.zeros(3)))
    for j, joint in enumerate(fit.joints):
        assert_recovers(joint, j)
        assert joint.inertia == pytest.approx(with_payload[j] + joint.armature)  # as model_inertia means it
    assert fit.residual_rms_nm < 0.01 * fit.residual_rms_without_payload_nm


def test_a_joint_that_never_moves_keeps_the_urdfs_values_and_says_why(arm3):
    time_s, q, v, tau, limit = record(arm3, variation(), amplitude=(0.4, 0.4, 0.0))
    fit = fit_chain(arm3, time_s, q, v, tau, effort_limit=limit)
    shoulder, elbow, wrist = fit.joints
    assert_recovers(shoulder, 0)
    assert_recovers(elbow, 1)
    assert not wrist.identified and "usable intervals" in wrist.reason
    assert (wrist.armature, wrist.damping, wrist.coulomb_friction) == (0.0, pytest.approx(0.002), 0.0)
    assert np.isnan(wrist.armature_stderr) and wrist.excluded_slow > 1900


def test_a_joint_that_moved_one_way_only_is_not_identified(arm3, nominal):
    time_s, q, v, tau, limit = nominal
    one_way = v.copy()
    one_way[:, 2] = np.abs(v[:, 2])  # the wrist's readings as if it had turned one way only
    wrist = fit_chain(arm3, time_s, q, one_way, tau, effort_limit=limit).joints[2]
    assert not wrist.identified and "one way only" in wrist.reason


def test_an_armature_below_the_urdfs_links_is_clipped_to_zero_and_said(arm3, tmp_path):
    # The URDF's hand turns about the wrist three times as hard as the real one: the wrist's inertia is below its
    # links' own, which the controller's chain model cannot take away (the hand's mass, so gravity, is the same).
    heavier_hand = tmp_path / "arm3_heavier_hand.urdf"
    heavier_hand.write_text(
        ARM3.replace('ixx="0.0002" ixy="0" ixz="0" iyy="0.0003"', 'ixx="0.0006" ixy="0" ixz="0" iyy="0.0003"')
    )
    time_s, q, v, tau, limit = record(arm3, variation(armature_kgm2=(0.02, 0.008, 0.0)))
    fit = fit_chain(heavier_hand, time_s, q, v, tau, effort_limit=limit)
    wrist = fit.joints[2]
    assert wrist.identified and wrist.clipped == ("armature",)
    assert wrist.armature == 0.0 and wrist.inertia == pytest.approx(wrist.urdf_inertia)
    assert wrist.fitted[0] == pytest.approx(-0.0004, rel=0.2)  # the URDF's hand is 0.0004 kg·m² too heavy
    assert "beyond 3 standard errors of 0" in wrist.below_zero("armature") and wrist.below_zero("damping") == ""
    assert wrist.coulomb_friction == pytest.approx(0.3, abs=0.05)
    assert not fit.payload_found
