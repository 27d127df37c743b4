"""External disturbances on the MuJoCo plant: an external torque on
the joint, beside the actuator's, for a given physics time (no ROS)."""

import numpy as np
import pytest

from robot_controller import resources
from robot_controller.core.model import MAX_DISTURBANCE_NM, MujocoPlant, check_disturbance

HANGING = np.array([-np.pi / 2])  # the reference arm at rest under gravity
BRAKE_NM = 50.0


def plant_at_rest() -> MujocoPlant:
    plant = MujocoPlant(resources.default_urdf(), 0.001)
    plant.reset(HANGING)
    return plant


def trace(plant: MujocoPlant, seconds: float, torque=(0.0,), batch: int = 10):
    """Positions and the disturbance that acted, after each batch of physics steps."""
    positions, applied = [], []
    for _ in range(round(seconds / (batch * plant.physics_dt))):
        plant.step(np.asarray(torque, dtype=float), batch)
        positions.append(plant.state()[0][0])
        applied.append(plant.disturbance_torque[0])
    return np.array(positions), np.array(applied)


def test_a_disturbance_moves_the_arm_for_its_duration_then_stops_acting():
    still, _ = trace(plant_at_rest(), 1.0)
    pushed = plant_at_rest()
    pushed.set_disturbance(np.array([2.0]), 0.5)
    assert pushed.disturbance_active and pushed.disturbance_remaining_s == pytest.approx(0.5)
    moved, applied = trace(pushed, 1.0)
    assert np.max(np.abs(still - HANGING[0])) < 1e-6  # no torque, no motion
    assert np.max(np.abs(moved - HANGING[0])) > 0.1  # 2 N·m on 0.083 kg·m²: about 0.2 rad in 0.5 s
    # It acted for the first 50 batches of 10 ms, and in none after.
    assert np.all(applied[:50] == 2.0) and np.all(applied[50:] == 0.0)
    assert not pushed.disturbance_active
    # Exactly a 2 N·m torque for 500 physics steps: the same as an actuator giving it.
    driven = plant_at_rest()
    driven_pushed, _ = trace(driven, 0.5, torque=(2.0,))
    driven_rest, _ = trace(driven, 0.5)
    np.testing.assert_allclose(moved, np.concatenate([driven_pushed, driven_rest]), atol=1e-9)


def test_a_disturbance_ending_between_two_batches_acts_for_its_own_time():
    one_step = plant_at_rest()
    one_step.set_disturbance(np.array([2.0]), 0.305)
    fine, _ = trace(one_step, 0.6, batch=1)
    batched = plant_at_rest()
    batched.set_disturbance(np.array([2.0]), 0.305)
    coarse, applied = trace(batched, 0.6, batch=10)
    np.testing.assert_allclose(coarse, fine[9::10], atol=1e-12)
    assert applied[29] == 2.0 and applied[30] == 0.0  # the batch it ended in ends without it


def test_the_disturbance_is_no_actuator_and_is_not_limited_to_the_effort_limit():
    limit = plant_at_rest().effort_limit[0]
    assert limit == pytest.approx(10.0)
    by_actuator = plant_at_rest()
    trace(by_actuator, 0.05, torque=(20.0,))  # clamped to 10 N·m
    assert by_actuator.applied_torque[0] == pytest.approx(10.0)
    by_push = plant_at_rest()
    by_push.set_disturbance(np.array([20.0]), 0.05)
    trace(by_push, 0.05)
    assert by_push.applied_torque[0] == 0.0  # the actuator gave nothing
    assert by_push.state()[0][0] - HANGING[0] > 1.5 * (by_actuator.state()[0][0] - HANGING[0])


def test_a_new_disturbance_replaces_the_current_one_and_zero_ends_it():
    plant = plant_at_rest()
    plant.set_disturbance(np.array([2.0]), 0.5)
    trace(plant, 0.1)
    plant.set_disturbance(np.array([-1.0]), 0.2)
    _, applied = trace(plant, 0.3)
    assert np.all(applied[:20] == -1.0) and np.all(applied[20:] == 0.0)
    plant.set_disturbance(np.array([3.0]), 1.0)
    plant.set_disturbance(np.array([3.0]), 0.0)
    assert not plant.disturbance_active
    plant.set_disturbance(np.array([3.0]), 1.0)
    plant.reset(HANGING)  # a reset arm is a new world
    assert not plant.disturbance_active


@pytest.mark.parametrize("torque", [2.0, 30.0])
def test_engaged_brakes_hold_the_joint_against_a_disturbance(torque):
    plant = plant_at_rest()
    plant.set_brakes(np.ones(1, dtype=bool), BRAKE_NM)
    plant.set_disturbance(np.array([torque]), 0.5)
    positions, applied = trace(plant, 0.6)
    assert np.all(applied[:50] == torque)  # it does act on the braked joint (as gravity does)
    assert np.max(np.abs(positions - HANGING[0])) < 1e-3
    assert plant.applied_torque[0] == 0.0  # and the actuator gives nothing to a braked joint
    # Released, the same push moves it.
    plant.set_brakes(np.zeros(1, dtype=bool), BRAKE_NM)
    plant.set_disturbance(np.array([torque]), 0.2)
    positions, _ = trace(plant, 0.2)
    assert np.max(np.abs(positions - HANGING[0])) > 0.01


def test_disturbance_messages_are_checked():
    torque, duration = check_disturbance([2.0, 0.5], 1)
    assert torque.tolist() == [2.0] and duration == 0.5
    assert check_disturbance([2.0, -1.0, 0.5], 2)[1] == 0.5
    assert "expected 2 values" in check_disturbance([2.0], 1)
    assert "expected 2 values" in check_disturbance([1.0, 2.0, 0.5], 1)
    assert "non-finite" in check_disturbance([float("nan"), 0.5], 1)
    assert "non-finite" in check_disturbance([1.0, float("inf")], 1)
    assert "negative duration" in check_disturbance([1.0, -0.1], 1)
    assert "over the 60 s limit" in check_disturbance([1.0, 60.5], 1)
    # Beyond the cap it is returned as sent: the simulator caps it and warns.
    assert check_disturbance([2 * MAX_DISTURBANCE_NM, 0.5], 1)[0][0] == 2 * MAX_DISTURBANCE_NM
