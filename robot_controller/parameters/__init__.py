"""Parameters of every node: what each means and accepts (``schema``), parameter files and presets (``files``), the
core's configs built from values (``builders``) and the whole-configuration check (``consistency``). No rclpy here."""

from robot_controller.parameters.builders import (
    controller_config,
    kalman_config,
    sensor_config,
    trajectory_kwargs,
)
from robot_controller.parameters.files import (
    Params,
    available_presets,
    load_stack,
    merge,
    params_yaml,
    read_params_file,
    write_params_file,
)
from robot_controller.parameters.schema import (
    NODES,
    SCHEMA,
    WORLD_WAITS,
    defaults,
    has,
    node_defaults,
    spec_of,
    world_waits,
)
from robot_controller.parameters.spec import ParamSpec, per_joint

__all__ = [
    "NODES",
    "SCHEMA",
    "WORLD_WAITS",
    "ParamSpec",
    "Params",
    "available_presets",
    "controller_config",
    "defaults",
    "has",
    "kalman_config",
    "load_stack",
    "merge",
    "node_defaults",
    "params_yaml",
    "per_joint",
    "read_params_file",
    "sensor_config",
    "spec_of",
    "trajectory_kwargs",
    "world_waits",
    "write_params_file",
]
