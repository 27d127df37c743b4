"""The core's configuration objects built from a node's parameter values."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.laws.parameters import PREFIX as LAW_PREFIX
from robot_controller.core.laws.pid import PidConfig
from robot_controller.core.model import SensorConfig
from robot_controller.parameters.spec import per_joint
from robot_controller.parameters.torque_limits import torque_limit

if TYPE_CHECKING:  # the controller pulls in scipy and MuJoCo: only the nodes that run one import it
    from robot_controller.core.controller import ControllerConfig
    from robot_controller.core.estimation import KalmanConfig
    from robot_controller.core.model import ArmDynamics, JointArmModel

# The controller's arm-model parameters, in the order of core.arm_model.PARAMETERS; empty = the URDF's.
MODEL_KEYS = ("model_inertia", "model_damping", "model_coulomb_friction", "model_gravity_torque")
# Every parameter of the controller's arm model: the per-joint ones and a payload on the last link.
ARM_MODEL_KEYS = (*MODEL_KEYS, "model_payload")


def given(value: Any) -> bool:
    """Whether a list parameter holds a value (empty or None: not set)."""
    return value is not None and np.size(value) > 0


def model_overridden(values: Mapping[str, Any]) -> bool:
    """Whether any of the controller's ``model_*`` parameters is set."""
    return any(given(values.get(key)) for key in MODEL_KEYS)


def arm_model(values: Mapping[str, Any]) -> ArmDynamics | JointArmModel:
    """The arm model the controller's model-based parts use: the URDF's (``ArmDynamics``), its per-joint
    values replaced by the ``model_*`` given. On one joint that is a ``JointArmModel`` (gravity m·g·l_c·cos q,
    as identify fits it); on a chain the coupled model keeps its coupling (``ArmDynamics.adjusted``), and
    gravity comes from the links' masses (a load the URDF lacks is ``model_payload``)."""
    from robot_controller import resources
    from robot_controller.core.estimation import KalmanConfig
    from robot_controller.core.model import ArmDynamics, JointArmModel, Payload

    payload = Payload.from_values("model_payload", values.get("model_payload"))
    # its inverse over the plant's step, the filter's model step (MuJoCo steps a wrist's damping implicitly)
    dynamics = ArmDynamics(resources.resolve_urdf(values["urdf_path"]), payload, step_s=KalmanConfig.model_step_s)
    if not model_overridden(values):
        return dynamics
    n = len(dynamics.joint_names)
    model = {key: per_joint(key, values[key], n) if given(values.get(key)) else None for key in MODEL_KEYS}
    if n > 1:
        if model["model_gravity_torque"] is not None:
            raise ConfigError(
                "model_gravity_torque: on a chain of joints gravity's torques come from the links' masses, which "
                "the model keeps; give a load the URDF lacks as model_payload"
            )
        return dynamics.adjusted(
            inertia=model["model_inertia"],
            damping=model["model_damping"],
            coulomb_friction=model["model_coulomb_friction"],
        )
    return JointArmModel.over_urdf(
        dynamics,
        inertia=model["model_inertia"],
        damping=model["model_damping"],
        coulomb_friction=model["model_coulomb_friction"],
        gravity_torque=model["model_gravity_torque"],
    )


def controller_config(values: Mapping[str, Any], joint_count: int) -> ControllerConfig:
    from robot_controller.core.controller import ControllerConfig

    def joints(name: str) -> np.ndarray:
        return per_joint(name, values[name], joint_count)

    pid = PidConfig(
        kp=joints("kp"),
        ki=joints("ki"),
        kd=joints("kd"),
        output_limit=torque_limit(values, joint_count),
        integral_limit=joints("integral_limit"),
        anti_windup=values["anti_windup"],
        back_calculation_time_s=values["back_calculation_time_s"],
        derivative_source=values["derivative_source"],
        derivative_filter_time_s=values["derivative_filter_time_s"],
        slew_rate_limit=values["slew_rate_limit"],
    )
    q = np.asarray(values["lqr_q"], dtype=float)  # three weights: the schema checks the length
    estimator = kalman_config(values) if values["estimator"] == "kalman" else None
    return ControllerConfig(
        pid=pid,
        controller_type=values["controller_type"],
        law_parameters={key[len(LAW_PREFIX) :]: value for key, value in values.items() if key.startswith(LAW_PREFIX)},
        law_budget_s=values["law_budget_s"],
        law_error_max_rad=values["law_error_max_rad"],
        stop_law=values["stop_law"],
        lqr_q=tuple(q.tolist()),
        lqr_r=values["lqr_r"],
        reference_inertia=values["reference_inertia"],
        # A payload's allowance makes the observer faster than a delay the stamps do not show allows: lockstep only.
        rated_payload_kg=values["rated_payload_kg"] if values["lockstep"] else 0.0,
        estimator=estimator,
        disturbance_observer=values["disturbance_observer"],
        inertia_adaptation=values["inertia_adaptation"],
        feedforward=values["feedforward"],
        feedback_decoupling=values["feedback_decoupling"],
        control_period_s=1.0 / values["control_rate_hz"],
        reference_extrapolation=values["reference_extrapolation"],
        latency_compensation=values["latency_compensation"],
        lockstep=values["lockstep"],
        watchdog_periods=values["watchdog_periods"],
        sensor_timeout_s=values["sensor_timeout_s"],
        max_reading_age_s=values["max_reading_age_s"],
        stop_deceleration=values["stop_deceleration"],
        reacquire_acceleration=values["reacquire_acceleration"],
        design_position=tuple(joints("design_position").tolist()) if given(values.get("design_position")) else None,
        # One value on a chain is for a joint of reference_inertia; one per joint is taken as given.
        scaled_gains=tuple(k for k in ("kp", "ki", "kd") if joint_count > 1 and np.size(values[k]) == 1),
        min_delay_margin_periods=values["min_delay_margin_periods"],
    )


def sensor_config(values: Mapping[str, Any]) -> SensorConfig:
    return SensorConfig(
        position_noise_std=values["position_noise_std"],
        velocity_noise_std=values["velocity_noise_std"],
        position_bias=values["position_bias"],
        quantization=values["quantization"],
        delay_s=values["delay_s"],
    )


# The planner's parameters that shape its trajectory (besides ``mode``).
TRAJECTORY_SHAPE_KEYS = ("amplitude", "frequency_hz", "offset", "step_time_s", "end_frequency_hz", "sweep_time_s")
TRAJECTORY_SHAPE_KEYS += ("step_shaping", "max_acceleration")


def trajectory_kwargs(values: Mapping[str, Any]) -> dict[str, Any]:
    shape = {key: values[key] for key in TRAJECTORY_SHAPE_KEYS}
    return {"joint_count": values["joint_count"], "sample_period_s": 1.0 / values["publish_rate_hz"], **shape}


def kalman_config(values: Mapping[str, Any]) -> KalmanConfig:
    """The controller's Kalman filter from its parameters. In lockstep each command acts from its tick
    exactly, and the filter trusts its model as configured. On the wall clock a command reaches the
    drive a few ms late and a push begins anywhere inside a period, which a filter that trusts its
    model cannot place: there it runs at its mismatch settings throughout and takes no jumps."""
    from dataclasses import replace

    from robot_controller.core.estimation import KalmanConfig

    config = KalmanConfig(
        values["kalman_position_noise_std"],
        values["kalman_velocity_noise_std"],
        values["kalman_acceleration_noise_std"],
        disturbance_noise_std=values["kalman_disturbance_noise_std"],
        jump_detection_sigma=values["kalman_disturbance_jump_sigma"],
        mismatch_acceleration_noise_std=values["kalman_mismatch_acceleration_noise_std"],
        mismatch_disturbance_noise_std=values["kalman_mismatch_disturbance_noise_std"],
        command_timing_uncertainty_s=0.0 if values["lockstep"] else values["kalman_command_timing_uncertainty_s"],
    )
    if values["lockstep"]:
        return config
    return replace(config.at_mismatch(), jump_detection_sigma=0.0)
