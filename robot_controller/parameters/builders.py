"""The core's configuration objects built from a node's parameter values."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import fields
from typing import TYPE_CHECKING, Any, TypeVar

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.laws.law_parameters import PREFIX as LAW_PREFIX
from robot_controller.core.laws.pid import PidConfig
from robot_controller.core.model import SensorConfig
from robot_controller.parameters.schema import has, spec_of, world_waits
from robot_controller.parameters.spec import per_joint
from robot_controller.parameters.torque_limits import torque_limit

if TYPE_CHECKING:  # the controller pulls in scipy and MuJoCo: only the nodes that run one import it
    from robot_controller.core.controller import ControllerConfig
    from robot_controller.core.estimation import KalmanConfig
    from robot_controller.core.model import ArmDynamics, JointArmModel

T = TypeVar("T")
# The node whose parameters make the controller's configs.
NODE = "pid_controller"
# The controller's arm-model parameters, in the order of core.arm_model.PARAMETERS; empty = the URDF's.
MODEL_KEYS = ("model_inertia", "model_damping", "model_coulomb_friction", "model_gravity_torque")
# Every parameter of the controller's arm model: the per-joint ones and a payload on the last link.
ARM_MODEL_KEYS = (*MODEL_KEYS, "model_payload")


def given(value: Any) -> bool:
    """Whether a list parameter holds a value (empty or None: not set)."""
    return value is not None and np.size(value) > 0


def model_overridden(values: Mapping[str, Any]) -> bool:
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


def from_values(
    cls: type[T],
    values: Mapping[str, Any],
    *,
    node: str,
    prefix: str = "",
    joint_count: int | None = None,
    **derived: Any,
) -> T:
    """A config dataclass from ``node``'s parameter values: each field from the parameter ``prefix`` + its name (a
    per-joint one with a value for each of ``joint_count`` joints) unless ``derived`` holds it; else the dataclass's
    default, which only a value that is no parameter has: the schema's defaults are the one set."""
    names = {f.name for f in fields(cls)}  # type: ignore[arg-type]
    assert set(derived) <= names, f"{cls.__name__} has no field {sorted(set(derived) - names)}"
    kwargs = dict(derived)
    for name in names - set(derived):
        key = prefix + name
        if key not in values:
            continue
        joints = joint_count is not None and has(node, key) and spec_of(node, key).per_joint
        kwargs[name] = per_joint(key, values[key], joint_count) if joints else values[key]
    return cls(**kwargs)


def pid_config(values: Mapping[str, Any], joint_count: int) -> PidConfig:
    """The built-in law's gains and options: the controller's parameters of the same names, its limit
    ``torque_max`` (each joint's URDF effort limit when empty)."""
    return from_values(
        PidConfig, values, node=NODE, joint_count=joint_count, output_limit=torque_limit(values, joint_count)
    )


def one_or_each(values: np.ndarray) -> float | tuple[float, ...]:
    """One number where every joint has the same, else one per joint (as a config compares and a line says it)."""
    return float(values[0]) if np.all(values == values[0]) else tuple(values.tolist())


def controller_config(values: Mapping[str, Any], joint_count: int) -> ControllerConfig:
    """The controller's config: each field from the parameter of its name, the few below worked out from theirs."""
    from robot_controller.core.controller import ControllerConfig

    return from_values(
        ControllerConfig,
        values,
        node=NODE,
        pid=pid_config(values, joint_count),
        law_parameters={key[len(LAW_PREFIX) :]: value for key, value in values.items() if key.startswith(LAW_PREFIX)},
        lqr_q=tuple(float(w) for w in values["lqr_q"]),  # three weights: the schema checks the length
        lqr_r=one_or_each(per_joint("lqr_r", values["lqr_r"], joint_count)),
        # A payload's allowance makes the observer faster than a delay the stamps do not show allows: only where the
        # world waits for each command (sim time, the paced world).
        world_waits=world_waits(values),
        rated_payload_kg=values["rated_payload_kg"] if world_waits(values) else 0.0,
        estimator=kalman_config(values) if values["estimator"] == "kalman" else None,
        control_period_s=1.0 / values["control_rate_hz"],
        design_position=tuple(per_joint("design_position", values["design_position"], joint_count).tolist())
        if given(values.get("design_position"))
        else None,
        # One value on a chain is for a joint of reference_inertia; one per joint is taken as given.
        scaled_gains=tuple(k for k in ("kp", "ki", "kd") if joint_count > 1 and np.size(values[k]) == 1),
    )


def sensor_config(values: Mapping[str, Any]) -> SensorConfig:
    """The encoder's noise, bias, quantisation and delay: the sensor's parameters of the same names."""
    return from_values(SensorConfig, values, node="sensor_node")


# The planner's parameters that shape its trajectory (besides ``mode``).
TRAJECTORY_SHAPE_KEYS = ("amplitude", "frequency_hz", "offset", "step_time_s", "end_frequency_hz", "sweep_time_s")
TRAJECTORY_SHAPE_KEYS += ("step_shaping", "max_acceleration")


def trajectory_kwargs(values: Mapping[str, Any]) -> dict[str, Any]:
    shape = {key: values[key] for key in TRAJECTORY_SHAPE_KEYS}
    return {"joint_count": values["joint_count"], "sample_period_s": 1.0 / values["publish_rate_hz"], **shape}


def kalman_config(values: Mapping[str, Any]) -> KalmanConfig:
    """The controller's Kalman filter from its ``kalman_*`` parameters. Where the world waits (sim time) each
    command acts from its tick exactly, and the filter trusts its model as configured. On the wall clock a command
    reaches the drive a few ms late and a push begins anywhere inside a period, which a filter that trusts its
    model cannot place: there it runs at its mismatch settings throughout and takes no jumps."""
    from dataclasses import replace

    from robot_controller.core.estimation import KalmanConfig

    config = from_values(
        KalmanConfig,
        values,
        node=NODE,
        prefix="kalman_",
        jump_detection_sigma=values["kalman_disturbance_jump_sigma"],
        command_timing_uncertainty_s=0.0 if world_waits(values) else values["kalman_command_timing_uncertainty_s"],
    )
    if world_waits(values):
        return config
    return replace(config.at_mismatch(), jump_detection_sigma=0.0)


def camera_model(values: Mapping[str, Any], model: Any) -> Any:
    """The camera the placement parameters say (``camera_position_m``, ``camera_target_m``, the image's size and field
    of view), the default one for the arm ``model`` (a MuJoCo model) where they give no place."""
    from robot_controller.core.vision.camera_model import CameraModel, default_camera

    width, height = int(values["image_width"]), int(values["image_height"])
    camera = default_camera(model, width, height)
    position, target = values.get("camera_position_m"), values.get("camera_target_m")
    return CameraModel(
        np.asarray(position, dtype=float) if given(position) else camera.position_m,
        np.asarray(target, dtype=float) if given(target) else camera.target_m,
        width,
        height,
        float(values["camera_fovy_deg"]),
    )
