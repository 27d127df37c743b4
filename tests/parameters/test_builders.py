"""The arm model the parameters build: the URDF's coupled model, adjusted by model_* on a chain (no ROS)."""

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError
from robot_controller.core.model import ArmDynamics
from robot_controller.parameters.builders import arm_model


def test_model_values_on_a_chain_adjust_the_coupled_model_and_never_replace_it():
    """planar2 with model_*: the mass matrix keeps its coupling (off-diagonal terms that move with the elbow),
    each joint's inertia at q = 0 is the value given, damping and friction are set; gravity is the links'."""
    values = dict(cfg.load_stack(robot="planar2")["pid_controller"])
    urdf = arm_model(values)
    inertia_urdf = np.diag(urdf.mass_matrix(np.zeros(2)))
    values.update(
        model_inertia=list(inertia_urdf + [0.05, 0.02]), model_damping=[0.3, 0.4], model_coulomb_friction=[0.1, 0.0]
    )
    model = arm_model(values)
    assert isinstance(model, ArmDynamics)
    np.testing.assert_allclose(np.diag(model.mass_matrix(np.zeros(2))), inertia_urdf + [0.05, 0.02])
    bent = model.mass_matrix(np.array([0.0, 1.2]))
    assert abs(bent[0, 1]) > 1e-3 and not np.isclose(bent[0, 1], model.mass_matrix(np.zeros(2))[0, 1])
    np.testing.assert_allclose(model.damping, [0.3, 0.4])
    np.testing.assert_allclose(model.gravity(np.array([0.3, 0.2])), urdf.gravity(np.array([0.3, 0.2])))
    assert "inertia" in model.describe() and "coupled" in model.describe()


def test_a_chain_refuses_less_inertia_than_its_links_and_a_gravity_torque_with_the_reason():
    values = dict(cfg.load_stack(robot="planar2")["pid_controller"])
    with pytest.raises(ConfigError, match=r"model_inertia: .* below its links' own"):
        arm_model({**values, "model_inertia": [1e-4, 1e-4]})
    with pytest.raises(ConfigError, match=r"model_gravity_torque: on a chain .* model_payload"):
        arm_model({**values, "model_gravity_torque": [1.0, 2.0]})
