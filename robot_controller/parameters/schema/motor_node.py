"""The motor node's parameters: the actuator's torque limit, its lag and its command timeout."""

from __future__ import annotations

from robot_controller.parameters.schema.shared import URDF, torque_max_spec
from robot_controller.parameters.spec import ParamSpec

MOTOR_NODE_PARAMS: tuple[ParamSpec, ...] = (
    URDF,
    torque_max_spec("actuator torque limit"),
    ParamSpec("lag_time_constant_s", float, 0.0, "first-order actuator lag time constant, s (0 = none)", minimum=0.0),
    ParamSpec(
        "command_timeout_s",
        float,
        0.05,
        "no valid /joint_commands for this long: zero torque and brake request (category 0) until commands return, s",
        minimum=0.0,
        exclusive_minimum=True,
    ),
)
