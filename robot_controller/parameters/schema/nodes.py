"""Every node's parameters by node name, and the look-ups on them (``spec_of``, ``has``, ``defaults``)."""

from __future__ import annotations

from robot_controller.parameters.schema.motor_node import MOTOR_NODE_PARAMS
from robot_controller.parameters.schema.pid_controller import PID_CONTROLLER_PARAMS
from robot_controller.parameters.schema.sensor_node import SENSOR_NODE_PARAMS
from robot_controller.parameters.schema.simulator import SIMULATOR_PARAMS
from robot_controller.parameters.schema.trajectory_planner import TRAJECTORY_PLANNER_PARAMS
from robot_controller.parameters.spec import ParamSpec

NODES = ("simulator", "motor_node", "sensor_node", "pid_controller", "trajectory_planner")
# Parameters rclpy declares on every node by itself.
ROS_BUILTIN = ("use_sim_time", "start_type_description_service")
# Parameters a node declares to report something it works out (read-only in effect); a parameter file
# that holds them (`robot-controller param dump`) is read without them.
REPORTED = ("law_in_force",)
# Parameters of the whole loop that several nodes declare: one value for all of them. A parameter file names them
# on any of these nodes (or under /**); the launcher hands the value to each (``files.load_stack``), and the
# whole-configuration check refuses two nodes that disagree (``consistency``).
LOOP_WIDE: dict[str, tuple[str, ...]] = {"control_rate_hz": ("simulator", "pid_controller")}

SCHEMA: dict[str, tuple[ParamSpec, ...]] = {
    "simulator": SIMULATOR_PARAMS,
    "motor_node": MOTOR_NODE_PARAMS,
    "sensor_node": SENSOR_NODE_PARAMS,
    "pid_controller": PID_CONTROLLER_PARAMS,
    "trajectory_planner": TRAJECTORY_PLANNER_PARAMS,
}


def spec_of(node: str, name: str) -> ParamSpec:
    """``node``'s parameter ``name``; ``KeyError`` if it has none."""
    for spec in SCHEMA[node]:
        if spec.name == name:
            return spec
    raise KeyError(f"{node}.{name}")


def has(node: str, name: str) -> bool:
    return any(spec.name == name for spec in SCHEMA[node])


def defaults() -> dict[str, dict]:
    """Every node's default values (the reference scenario with the default controller)."""
    return {node: {spec.name: spec.default_value() for spec in specs} for node, specs in SCHEMA.items()}


def node_defaults(node: str) -> dict:
    """``node``'s default values: the one set the core's configs are made from (``parameters.builders``)."""
    return {spec.name: spec.default_value() for spec in SCHEMA[node]}
