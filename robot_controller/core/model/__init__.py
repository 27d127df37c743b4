"""The arm: its URDF model and coupled dynamics, the MuJoCo plant, payloads,
identification, and the simulated drive and encoder."""

from robot_controller.core.model.actuator import Actuator
from robot_controller.core.model.arm_dynamics import ArmDynamics, matrix_power
from robot_controller.core.model.arm_model import PARAMETERS, JointArmModel
from robot_controller.core.model.chain_identification import ChainFit, ChainJointFit, fit_chain
from robot_controller.core.model.identification import IdentificationError, JointFit, identify
from robot_controller.core.model.joint_limits import JointLimits, joint_limits, urdf_velocity_limits
from robot_controller.core.model.mujoco_model import (
    can_collide,
    effort_limits,
    joint_names,
    load_model,
    steps_per_period,
)
from robot_controller.core.model.mujoco_plant import (
    MAX_DISTURBANCE_NM,
    MujocoPlant,
    check_disturbance,
)
from robot_controller.core.model.payload import Payload
from robot_controller.core.model.payload_identification import fit_payload
from robot_controller.core.model.plant import Plant
from robot_controller.core.model.plant_variation import PlantVariation
from robot_controller.core.model.sensor_model import DelayLine, SensorConfig, measure

__all__ = [
    "MAX_DISTURBANCE_NM",
    "PARAMETERS",
    "Actuator",
    "ArmDynamics",
    "ChainFit",
    "ChainJointFit",
    "DelayLine",
    "IdentificationError",
    "JointArmModel",
    "JointFit",
    "JointLimits",
    "MujocoPlant",
    "Payload",
    "Plant",
    "PlantVariation",
    "SensorConfig",
    "can_collide",
    "check_disturbance",
    "effort_limits",
    "fit_chain",
    "fit_payload",
    "identify",
    "joint_limits",
    "joint_names",
    "load_model",
    "matrix_power",
    "measure",
    "steps_per_period",
    "urdf_velocity_limits",
]
