"""The motor node's parameters: the actuator's torque limit, its lag, its command timeout and the
oldest command it applies."""

from __future__ import annotations

from robot_controller.blocks import spec
from robot_controller.parameters.schema.shared import POSITIVE, SAFETY, URDF, torque_max_spec, world_waits_spec
from robot_controller.parameters.spec import ParamSpec

# One line per parameter: the schema reads as a table.
# fmt: off
MOTOR_NODE_PARAMS: tuple[ParamSpec, ...] = (
    URDF,
    torque_max_spec("actuator torque limit", safety=True),
    ParamSpec("lag_time_constant_s", float, 0.0, "first-order actuator lag time constant, s (0 = none)", minimum=0.0),
    ParamSpec("command_timeout_s", float, 0.05, f"no valid {spec.COMMAND.topic} for this long: zero torque and brake request (category 0) until commands return, s; at most 0.2 s: a dead controller's last torque acts that long (two periods at the slowest control rate)", **POSITIVE, maximum=0.2, **SAFETY),
    ParamSpec("max_command_age_s", float, 0.03, f"a {spec.COMMAND.topic} stamped with its tick (ours are) that arrives more than this after the tick is dropped, as no command: the controller's gains survive 2 periods (20 ms) of delay it does not know of, and feedback later than that swings the arm (wall clock only: on sim time no time passes between ticks), s; at most 0.2 s, the longest command timeout: an older command is one the drive would have braked for", **POSITIVE, maximum=0.2, **SAFETY),
    world_waits_spec("on the sim's clock: each command's time is the tick it is stamped with (no timeout, no age check)"),
)
# fmt: on
