"""Identification of an arm from a recorded motion (no ROS), the arm model it
feeds, and the controller parameters that carry it."""

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.errors import ConfigError
from robot_controller.core.model import (
    PARAMETERS,
    ArmDynamics,
    IdentificationError,
    JointArmModel,
    MujocoPlant,
    identify,
)
from robot_controller.core.reference import Chirp
from robot_controller.parameters import consistency
from robot_controller.parameters.builders import arm_model

HEAVY_URDF = resources.share_dir() / "description" / "heavy_arm.urdf"
CONTROL_PERIOD_S = 0.01


def truth(urdf) -> dict[str, float]:
    """The arm's four model values as MuJoCo computes them from its URDF."""
    model = JointArmModel.over_urdf(ArmDynamics(urdf))
    return {
        "inertia": float(model.inertia[0]),
        "damping": float(model.damping[0]),
        "coulomb_friction": float(model.coulomb_friction[0]),
        "gravity_torque": float(model.gravity_torque[0]),
    }


def record(urdf, duration_s: float = 12.0):
    """A MuJoCo run of ``urdf`` following a chirp under a PD with a rough model feedforward,
    the torque held over each 10 ms period: ``(time, position, velocity, torque)`` where
    row k's torque is the one that acted from sample k-1 to k (as the simulator reports it)."""
    plant = MujocoPlant(urdf, 0.001)
    plant.reset(np.zeros(1))
    chirp = Chirp(np.array([0.8]), 0.2, 1.0, duration_s, np.zeros(1))
    rows = [(0.0, 0.0, 0.0, 0.0)]
    steps = int(round(CONTROL_PERIOD_S / plant.physics_dt))
    for k in range(int(round(duration_s / CONTROL_PERIOD_S))):
        q_ref, v_ref, a_ref = chirp.sample(k * CONTROL_PERIOD_S)
        q, v = plant.state()
        u = 0.3 * a_ref + 0.2 * v_ref + 7.0 * np.cos(q_ref) + 200.0 * (q_ref - q) + 20.0 * (v_ref - v)
        plant.step(np.clip(u, -10.0, 10.0), steps)
        q, v = plant.state()
        rows.append((plant.time_s, q[0], v[0], float(plant.applied_torque[0])))
    return tuple(np.array(column) for column in zip(*rows, strict=True))


@pytest.fixture(scope="module")
def heavy_recording():
    return record(HEAVY_URDF)


def test_heavy_arm_is_four_times_the_inertia_and_three_times_the_gravity_of_the_reference():
    heavy, reference = truth(HEAVY_URDF), truth(resources.default_urdf())
    assert heavy["inertia"] / reference["inertia"] == pytest.approx(4.0, rel=0.01)
    assert heavy["gravity_torque"] / reference["gravity_torque"] == pytest.approx(3.0, rel=0.01)
    assert heavy["coulomb_friction"] > 0 and reference["coulomb_friction"] == 0
    assert ArmDynamics(HEAVY_URDF).joint_names == ArmDynamics(resources.default_urdf()).joint_names
    np.testing.assert_array_equal(ArmDynamics(HEAVY_URDF).effort_limit, [10.0])


def test_recovers_a_known_arm_within_5_percent(heavy_recording):
    time_s, q, v, tau = heavy_recording
    assert np.any(np.abs(tau) >= 10.0)  # some saturated: they must be left out
    fit = identify(time_s, q, v, tau, effort_limit=10.0)[0]
    for name, value in truth(HEAVY_URDF).items():
        assert getattr(fit, name) == pytest.approx(value, rel=0.05), name
        assert 0 < getattr(fit, f"{name}_stderr") < 0.05 * value, name
    assert fit.excluded_saturated > 0 and fit.excluded_slow > 0
    assert fit.residual_rms_nm < 0.05
    assert fit.samples > 500


def test_recovers_it_from_noisy_readings_with_more_smoothing(heavy_recording):
    time_s, q, v, tau = heavy_recording
    rng = np.random.default_rng(0)
    noisy_q, noisy_v = q + rng.normal(0, 0.005, q.shape), v + rng.normal(0, 0.02, v.shape)
    fit = identify(time_s, noisy_q, noisy_v, tau, effort_limit=10.0, window=15)[0]
    for name, value in truth(HEAVY_URDF).items():
        assert getattr(fit, name) == pytest.approx(value, rel=0.05), name


def test_braked_and_torque_off_samples_are_left_out(heavy_recording):
    time_s, q, v, tau = heavy_recording
    tau = tau.copy()
    braked = np.zeros(len(time_s), dtype=bool)
    braked[300:400] = True
    tau[300:400] = 50.0  # what a brake does is not in the model
    tau[600:620] = 0.0  # torque off
    fit = identify(time_s, q, v, tau, effort_limit=10.0, braked=braked)[0]
    assert fit.excluded_braked >= 120
    for name, value in truth(HEAVY_URDF).items():
        assert getattr(fit, name) == pytest.approx(value, rel=0.05), name


def test_a_motion_that_does_not_excite_the_model_is_refused():
    time_s = np.arange(200) * 0.01
    with pytest.raises(IdentificationError):  # at rest: nothing usable
        identify(time_s, np.zeros(200), np.zeros(200), np.full(200, 2.0))
    v = np.full(200, 0.5)  # constant speed, no acceleration: inertia cannot be told
    with pytest.raises(IdentificationError, match="rank-deficient"):
        identify(time_s, np.full(200, 0.3), v, np.full(200, 2.0), window=1)


# --- the arm model ------------------------------------------------------------------


def test_model_over_the_reference_urdf_agrees_with_mujoco():
    urdf = ArmDynamics(resources.default_urdf())
    model = JointArmModel.over_urdf(urdf)
    assert model.joint_names == urdf.joint_names
    np.testing.assert_allclose(model.mass_matrix(np.zeros(1)), urdf.mass_matrix(np.zeros(1)))
    np.testing.assert_allclose(model.damping, urdf.damping)
    for q, v, a in [(0.0, 0.0, 0.0), (0.7, 1.5, -3.0), (-1.2, -2.0, 8.0), (2.5, 0.3, 1.0)]:
        state = np.array([q]), np.array([v]), np.array([a])
        np.testing.assert_allclose(model.torque(*state), urdf.torque(*state), atol=1e-9)
        np.testing.assert_allclose(model.gravity(state[0]), urdf.gravity(state[0]), atol=1e-9)
        tau = np.array([3.0])
        np.testing.assert_allclose(
            model.acceleration(state[0], state[1], tau), urdf.acceleration(state[0], state[1], tau), rtol=1e-9
        )


def test_model_predicts_the_heavy_arm_as_mujoco_simulates_it():
    model = JointArmModel.over_urdf(ArmDynamics(HEAVY_URDF))
    plant = MujocoPlant(HEAVY_URDF, 0.001)
    for q0, v0, tau in [(0.2, 1.5, 6.0), (-0.5, -2.0, 4.0), (0.8, 0.5, 9.0)]:
        plant.reset(np.array([q0]), np.array([v0]))
        plant.step(np.array([tau]), 20)
        q_true, v_true = plant.state()
        q, v = model.predict(np.array([q0]), np.array([v0]), np.array([tau]), 0.02)
        assert abs(q[0] - q_true[0]) < 2e-4 and abs(v[0] - v_true[0]) < 0.02


def test_model_friction_sticks_at_rest_and_never_reverses_a_joint():
    model = JointArmModel(["j"], [0.1], [0.0], [1.0], [0.0])
    np.testing.assert_array_equal(model.acceleration(np.zeros(1), np.zeros(1), np.array([0.5])), [0.0])
    assert model.acceleration(np.zeros(1), np.zeros(1), np.array([1.5]))[0] == pytest.approx(5.0)
    _, v = model.predict(np.zeros(1), np.array([0.05]), np.zeros(1), 0.1)
    assert v[0] == 0.0
    assert model.torque(np.zeros(1), np.array([-1.0]), np.zeros(1))[0] == pytest.approx(-1.0)


def test_model_refuses_impossible_values():
    with pytest.raises(ConfigError):
        JointArmModel(["j"], [0.0], [0.1], [0.0], [1.0])
    with pytest.raises(ConfigError):
        JointArmModel(["j"], [0.1], [-0.1], [0.0], [1.0])
    with pytest.raises(ConfigError):
        JointArmModel(["j", "k"], [0.1], [0.1], [0.0], [1.0])


# --- the controller's model_* parameters ---------------------------------------------


def test_model_parameters_default_to_empty_and_the_urdf():
    params = cfg.load_stack("default")
    for key in ("model_inertia", "model_damping", "model_coulomb_friction", "model_gravity_torque"):
        assert params["pid_controller"][key] == []
    assert type(arm_model(params["pid_controller"])) is ArmDynamics  # unchanged: MuJoCo on the URDF


def test_an_empty_list_is_accepted_only_where_allowed():
    spec = cfg.spec_of("pid_controller", "model_inertia")
    assert spec.validate([]) == [] and spec.validate(None) == []  # rclpy reads a file's [] as no value
    assert spec.validate([0.3]) == [0.3]
    with pytest.raises(ConfigError):
        spec.validate([0.0])  # inertia > 0
    with pytest.raises(ConfigError):
        cfg.spec_of("pid_controller", "kp").validate([])


def test_model_overlay_replaces_the_urdf_and_partial_values_fill_from_it(tmp_path):
    overlay = tmp_path / "identified.yaml"
    cfg.write_params_file({"pid_controller": {"model_inertia": [0.3], "model_gravity_torque": [7.0]}}, overlay)
    params = cfg.load_stack("default", [overlay])
    consistency.check_stack(params)
    model = arm_model(params["pid_controller"])
    assert isinstance(model, JointArmModel)
    assert model.inertia.tolist() == [0.3] and model.gravity_torque.tolist() == [7.0]
    assert model.damping.tolist() == pytest.approx([0.1]) and model.coulomb_friction.tolist() == [0.0]
    assert model.source == {
        "inertia": "parameter",
        "damping": "URDF",
        "coulomb_friction": "URDF",
        "gravity_torque": "parameter",
    }
    assert set(PARAMETERS) == set(model.source)


def test_a_model_value_per_joint_of_the_wrong_count_is_refused(tmp_path):
    bad = tmp_path / "bad.yaml"
    cfg.write_params_file({"pid_controller": {"model_damping": [0.1, 0.2]}}, bad)
    with pytest.raises(ConfigError, match="model_damping"):
        consistency.check_stack(cfg.load_stack("default", [bad]))
