"""The plant the controller does not know: each simulator parameter changes the simulated arm's physics by what it
says, refuses a bad value naming its key, and leaves the controller's model as its URDF."""

import math

import mujoco
import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError
from robot_controller.core.model import ArmDynamics, MujocoPlant, Payload, PlantVariation
from robot_controller.experiments import inprocess
from robot_controller.parameters.consistency import check_stack
from robot_controller.robots import ROBOTS, urdf_of

PANDA = urdf_of("panda")
HOME = np.array(ROBOTS["panda"].home_position)


def held(plant: MujocoPlant, torque: np.ndarray, steps: int) -> np.ndarray:
    """How far each joint moves from HOME in ``steps`` physics steps of ``torque``, rad."""
    plant.reset(HOME)
    plant.step(torque, steps)
    return plant.state()[0] - HOME


def test_the_defaults_change_nothing():
    variation = PlantVariation.from_params(cfg.defaults()["simulator"])
    assert variation.nominal and variation.describe() == ""
    plain, varied = MujocoPlant(PANDA), MujocoPlant(PANDA, variation=variation)
    for name in ("dof_frictionloss", "dof_damping", "dof_armature", "body_mass", "body_inertia", "dof_solref"):
        np.testing.assert_array_equal(getattr(varied.model, name), getattr(plain.model, name))


def test_friction_holds_a_joint_below_its_breakaway_torque_and_takes_its_value_off_a_sliding_one():
    gravity = ArmDynamics(PANDA).gravity(HOME)
    push = np.zeros(7)
    push[6] = 0.5  # on the wrist, half the friction below
    free = held(MujocoPlant(PANDA), gravity + push, 1000)
    rough = MujocoPlant(PANDA, variation=PlantVariation(joint_friction_nm=(1.0,)))
    assert abs(free[6]) > 1.0  # the wrist spins away without friction
    assert np.all(np.abs(held(rough, gravity + push, 1000)) < 2e-3)  # held: under 2 mrad in a second
    # Sliding, 1.5 N·m against 1 N·m of friction moves the wrist as 0.5 N·m moves it without: (mostly: the other
    # joints, held by their friction too, are a little stiffer than free ones).
    slid = held(rough, gravity + 3 * push, 30)
    np.testing.assert_allclose(slid[6], held(MujocoPlant(PANDA), gravity + push, 30)[6], rtol=0.05)


def test_damping_adds_a_torque_against_the_speed():
    velocity = np.linspace(-1.0, 1.0, 7)
    plain, damped = MujocoPlant(PANDA), MujocoPlant(PANDA, variation=PlantVariation(joint_damping_nms=(0.7,)))
    for plant in (plain, damped):
        plant.reset(HOME, velocity)
    added = damped.data.qfrc_passive - plain.data.qfrc_passive
    np.testing.assert_allclose(added, -0.7 * velocity, atol=1e-12)


def test_armature_adds_to_each_joints_own_inertia_one_value_per_joint():
    armature = (0.1, 0.2, 0.0, 0.05, 0.0, 0.01, 0.02)
    plain, geared = MujocoPlant(PANDA), MujocoPlant(PANDA, variation=PlantVariation(armature_kgm2=armature))
    masses = []
    for plant in (plain, geared):
        plant.reset(HOME)
        matrix = np.zeros((7, 7))
        mujoco.mj_fullM(plant.model, plant.data, matrix)
        masses.append(matrix)
    np.testing.assert_allclose(masses[1] - masses[0], np.diag(armature), atol=1e-12)


def test_link_mass_scale_scales_gravity_by_the_factor_and_one_per_joint_scales_what_that_joint_moves():
    plain, heavier = MujocoPlant(PANDA), MujocoPlant(PANDA, variation=PlantVariation(link_mass_scale=(1.1,)))
    for plant in (plain, heavier):
        plant.reset(HOME)
    np.testing.assert_allclose(heavier.data.qfrc_bias, 1.1 * plain.data.qfrc_bias, rtol=1e-9, atol=1e-12)
    # Only the links the wrist moves (its link, the hand, the fingers) twice as heavy: only its mass doubles.
    wrist = MujocoPlant(PANDA, variation=PlantVariation(link_mass_scale=(1,) * 6 + (2,)))
    massive = plain.model.body_mass > 0
    ratio = wrist.model.body_mass[massive] / plain.model.body_mass[massive]
    moved_by_wrist = (np.arange(plain.model.nbody) >= plain.model.jnt_bodyid[6])[massive]  # the chain's last bodies
    assert moved_by_wrist.sum() >= 3  # the wrist's link, the hand and its fingers
    assert np.all(ratio[moved_by_wrist] == 2.0) and np.all(ratio[~moved_by_wrist] == 1.0)


def test_the_payload_in_either_form_is_the_same_load_and_not_scaled_with_the_links():
    old = PlantVariation.from_params({"payload": [3.0, 0.0, 0.0, 0.1]})
    new = PlantVariation.from_params({"payload_kg": 3.0, "payload_offset_m": [0.0, 0.0, 0.1]})
    assert old.payload == new.payload == Payload(3.0, (0.0, 0.0, 0.1))
    loaded = MujocoPlant(PANDA, variation=PlantVariation(link_mass_scale=(1.5,), payload=new.payload))
    assert loaded.model.body("robot_controller_payload").mass[0] == 3.0
    plain, varied = MujocoPlant(PANDA, payload=old.payload), MujocoPlant(PANDA, variation=new)
    for plant in (plain, varied):
        plant.reset(HOME)
    np.testing.assert_array_equal(varied.data.qfrc_bias, plain.data.qfrc_bias)
    assert PlantVariation.from_params({"payload_kg": 0.0, "payload_offset_m": [0.0, 0.0, 0.1]}).payload is None


@pytest.mark.parametrize(
    ("params", "named"),
    [
        ({"joint_friction_nm": [-0.1]}, "joint_friction_nm: must be >= 0"),
        ({"joint_damping_nms": [math.nan]}, "joint_damping_nms: must be finite"),
        ({"armature_kgm2": [math.inf, 0.0]}, "armature_kgm2: must be finite"),
        ({"link_mass_scale": [0.0]}, "link_mass_scale: must be > 0"),
        ({"payload_kg": -1.0}, "payload_kg: must be a finite mass >= 0"),
        ({"payload_kg": 1.0, "payload_offset_m": [0.0, 0.0, 9.0]}, "payload_offset_m: its centre"),
        ({"payload": [1.0, 0.0, 0.0, 0.1], "payload_kg": 1.0}, "payload_kg: set either payload"),
        ({"payload": [1.0, 0.0, 0.0, 0.1], "payload_offset_m": [0.0, 0.0, 0.1]}, "not both"),
    ],
)
def test_a_bad_value_is_refused_naming_its_key_and_why(params, named):
    with pytest.raises(ConfigError, match="simulator.") as refused:
        PlantVariation.from_params(params, "simulator.")
    assert named in str(refused.value)


def test_a_per_joint_value_of_the_wrong_length_is_refused_naming_its_key():
    with pytest.raises(ConfigError, match="joint_friction_nm: expected 1 or 7 values"):
        MujocoPlant(PANDA, variation=PlantVariation(joint_friction_nm=(1.0, 2.0)))


def test_the_schema_refuses_what_the_plant_would():
    specs = {spec.name: spec for spec in cfg.SCHEMA["simulator"]}
    for name, bad in [("joint_friction_nm", [-1.0]), ("armature_kgm2", [math.nan]), ("link_mass_scale", [0.0])]:
        with pytest.raises(ConfigError, match=name):
            specs[name].validate(bad)
    params = cfg.merge(cfg.load_stack(), {"simulator": {"payload": [1.0, 0, 0, 0], "payload_kg": 1.0}})
    with pytest.raises(ConfigError, match="simulator: payload_kg: set either payload"):
        check_stack(params)


def test_the_in_process_loop_varies_its_plant_and_not_its_controllers_model():
    varied = {"joint_friction_nm": 1.5, "joint_damping_nms": 1.0, "armature_kgm2": 0.1, "link_mass_scale": 0.9}
    params = cfg.merge(cfg.load_stack(robot="panda"), {"simulator": dict(varied, payload_kg=1.5)})
    run = inprocess.prepare(params, duration_s=0.1)
    run()  # the world's start-up brakes released by the first effort: the plant's own friction shows
    plant, controller = run.keywords["world"].plant.model, run.keywords["controller"].dynamics.model
    urdf = ArmDynamics(PANDA).model
    assert np.all(plant.dof_frictionloss == 1.5) and np.all(plant.dof_armature == 0.1)
    assert plant.body("robot_controller_payload").mass[0] == 1.5
    for name in ("dof_frictionloss", "dof_damping", "dof_armature", "body_mass", "body_inertia"):
        np.testing.assert_array_equal(getattr(controller, name), getattr(urdf, name))
