"""Which of a joint's fitted values the data tells from the URDF's (no ROS): a joint's columns ``[a, v, sign(v)]``
over a chirp, the torque its URDF's values give plus what a simulated arm's fit leaves (noise, and a model error in
proportion to speed, as the Panda's damping takes up)."""

import numpy as np
import pytest

from robot_controller.core.model.chain_parsimony import parsimonious

URDF = np.array([0.0, 0.003, 0.0])  # armature added, damping, friction: a Panda joint's


def columns() -> np.ndarray:
    t = np.arange(0.0, 20.0, 0.01)
    phase = 2 * np.pi * (0.1 * t + 0.01 * t**2)  # 0.1 → 0.5 Hz
    rate = 2 * np.pi * (0.1 + 0.02 * t)
    v = 0.4 * rate * np.cos(phase)
    a = -0.4 * rate**2 * np.sin(phase) + 0.4 * 2 * np.pi * 0.02 * np.cos(phase)
    keep = np.abs(v) > 0.05
    return np.column_stack([a, v, np.sign(v)])[keep]


def torque(X: np.ndarray, values: np.ndarray, seed: int = 0) -> np.ndarray:
    noise = np.random.default_rng(seed).normal(0.0, 0.005, len(X))
    return X @ values + 0.01 * X[:, 1] + noise  # 0.01 N·m·s/rad of model error: the velocity column takes it up


def test_a_joint_that_is_the_urdfs_keeps_the_urdfs_values():
    X = columns()
    fit = parsimonious(X, torque(X, URDF), URDF, friction_column=2, friction_floor_nm=0.012)
    free = np.linalg.lstsq(X, torque(X, URDF), rcond=None)[0]
    assert free[1] > 3 * URDF[1]  # what the least squares alone would impose
    assert fit.kept == (True, True, True) and fit.values == pytest.approx(URDF)
    assert all(0.0 <= c < 2.0 for c in fit.cost)


def test_values_the_joint_adds_are_told_and_recovered():
    X = columns()
    truth = np.array([0.005, 0.05, 0.3])  # a rotor, damping and friction its URDF lacks
    fit = parsimonious(X, torque(X, truth), URDF, friction_column=2, friction_floor_nm=0.012)
    assert fit.kept == (False, False, False)
    assert fit.values[0] == pytest.approx(truth[0], rel=0.2)
    assert fit.values[1] == pytest.approx(truth[1], rel=0.3)  # with the model error's 0.01
    assert fit.values[2] == pytest.approx(truth[2], abs=0.05)


def test_a_friction_under_the_floor_is_none():
    X = columns()
    truth = URDF + [0.0, 0.0, 0.005]  # told by the residual, but under 0.1 % of a 12 N·m joint's limit
    fit = parsimonious(X, torque(X, truth, seed=1) - 0.01 * X[:, 1], URDF, friction_column=2, friction_floor_nm=0.012)
    assert fit.kept[2] and fit.values[2] == 0.0
