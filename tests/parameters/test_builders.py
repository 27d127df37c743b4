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


def test_the_configs_are_the_schemas_defaults_with_nothing_of_their_own():
    """The core's configs have no defaults: made from the schema's values, each field is its parameter's."""
    values = cfg.node_defaults("pid_controller")
    config = cfg.controller_config(values, 1)
    assert (config.controller_type, config.lqr_r, config.feedforward.value) == ("lqr", 10.0, "full")
    assert config.estimator is not None and config.estimator.command_timing_uncertainty_s == 0.01  # the wall clock's:
    assert config.estimator.acceleration_noise_std == values["kalman_mismatch_acceleration_noise_std"]  # mismatched
    assert config.pid.anti_windup.value == values["anti_windup"] and list(config.pid.output_limit) == [10.0]
    lockstep = cfg.kalman_config(values | {"lockstep": True})
    assert lockstep.command_timing_uncertainty_s == 0.0 and lockstep.jump_detection_sigma == 5.0
    sensor = cfg.sensor_config(cfg.node_defaults("sensor_node") | {"delay_s": 0.02})
    assert (sensor.position_noise_std, sensor.delay_s) == (0.005, 0.02)
    with pytest.raises(TypeError, match="required"):
        cfg.sensor_config({"position_noise_std": 0.005})  # a value missing is a bug, never a default of its own
