"""Dry friction in the controller's model: the torque a motion needs carries all of a light joint's friction once it
moves, turning over smoothly through zero speed; friction given over the URDF sticks in the model's forward
prediction as the simulated arm's does; the URDF's own friction stays MuJoCo's, as the simulator has it."""

from pathlib import Path

import mujoco
import numpy as np
import pytest

from robot_controller.core.model import ArmDynamics, PlantVariation, load_model
from robot_controller.core.model.friction import COULOMB_SMOOTH_RAD_S, coulomb_torque

ARM = Path(__file__).resolve().parents[3] / "examples" / "light_wrist_arm.urdf"
FRICTION_NM = np.array([0.5, 0.4, 0.3])


def friction_needed(dynamics: ArmDynamics, speed: float) -> np.ndarray:
    rest = dynamics.torque(np.zeros(3), np.zeros(3), np.zeros(3))
    damping = dynamics.damping[:3] * speed
    return dynamics.torque(np.zeros(3), np.full(3, speed), np.zeros(3)) - rest - damping


def test_a_light_wrist_moving_needs_all_of_its_friction():
    given = ArmDynamics(ARM).adjusted(coulomb_friction=FRICTION_NM)
    np.testing.assert_allclose(friction_needed(given, 0.1), FRICTION_NM, rtol=1e-6)
    np.testing.assert_allclose(friction_needed(given, -0.1), -FRICTION_NM, rtol=1e-6)
    # MuJoCo's soft friction gives the wrist a third of it at 0.5 rad/s: the feedforward would leave it stuck.
    soft = ArmDynamics(ARM)
    soft.model.dof_frictionloss[:3] = FRICTION_NM
    assert friction_needed(soft, 0.5)[2] < 0.5 * FRICTION_NM[2]


def test_the_friction_turns_over_smoothly_through_zero_speed():
    speeds = np.linspace(-0.05, 0.05, 101)
    torque = coulomb_torque(0.3, speeds)
    assert np.all(np.diff(torque) > 0) and torque[50] == 0.0
    assert np.max(np.abs(np.diff(torque))) < 0.3 * 0.001 / COULOMB_SMOOTH_RAD_S  # no jump of a tick
    assert coulomb_torque(0.3, 3 * COULOMB_SMOOTH_RAD_S) == pytest.approx(0.3, rel=0.01)


def test_given_friction_sticks_in_the_prediction_as_in_the_simulated_arm():
    """A wrist pushed at 80 % of its breakaway for 0.5 s: the controller's model creeps as the plant does (the same
    numbers), not the 0.6 rad MuJoCo's soft friction would let it slide."""
    given = ArmDynamics(ARM).adjusted(coulomb_friction=FRICTION_NM)
    push = given.gravity(np.zeros(3)) + np.array([0.0, 0.0, 0.8 * FRICTION_NM[2]])
    position, _ = given.predict(np.zeros(3), np.zeros(3), push, 0.5)
    plant_model = load_model(ARM)
    PlantVariation(joint_friction_nm=tuple(FRICTION_NM)).apply(plant_model)
    data = mujoco.MjData(plant_model)
    data.qfrc_applied[:] = push
    mujoco.mj_step(plant_model, data, round(0.5 / plant_model.opt.timestep))
    np.testing.assert_allclose(position, data.qpos, atol=1e-6)
    assert abs(position[2]) < 0.02
    soft = ArmDynamics(ARM)
    soft.model.dof_frictionloss[:3] = FRICTION_NM
    assert abs(soft.predict(np.zeros(3), np.zeros(3), push, 0.5)[0][2]) > 0.3


def test_the_urdfs_own_friction_stays_mujocos():
    plain = ArmDynamics(ARM)
    assert plain.coulomb_friction is None
    model = load_model(ARM)
    data = mujoco.MjData(model)
    data.qvel[:] = 0.3
    mujoco.mj_inverse(model, data)
    np.testing.assert_allclose(plain.torque(np.zeros(3), np.full(3, 0.3), np.zeros(3)), data.qfrc_inverse)
