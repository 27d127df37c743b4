"""Every parameter of every node, one entry each: type, default, description,
accepted range or choices, per joint or not, read-only or not (in the spirit
of generate_parameter_library). The nodes declare their parameters from
here, ``robot-controller params`` prints them, and ``params --yaml`` writes
the defaults as a ROS 2 parameter file.

One module per node holds its entries; ``shared`` holds the specs several
nodes declare. Rates have a floor and a ceiling this stack can keep: a rate
beyond it starves the loop, one below it leaves the watchdog with nothing to
watch.
"""

from __future__ import annotations

from robot_controller.parameters.schema.motor_node import MOTOR_NODE_PARAMS
from robot_controller.parameters.schema.pid_controller import PID_CONTROLLER_PARAMS
from robot_controller.parameters.schema.sensor_node import SENSOR_NODE_PARAMS
from robot_controller.parameters.schema.shared import URDF
from robot_controller.parameters.schema.simulator import SIMULATOR_PARAMS
from robot_controller.parameters.schema.trajectory_planner import TRAJECTORY_PLANNER_PARAMS
from robot_controller.parameters.spec import ParamSpec

NODES = ("simulator", "motor_node", "sensor_node", "pid_controller", "trajectory_planner")
# Parameters rclpy declares on every node by itself.
ROS_BUILTIN = ("use_sim_time", "start_type_description_service")
# Parameters a node declares to report something it works out (read-only in effect); a parameter file
# that holds them (`robot-controller param dump`) is read without them.
REPORTED = ("law_in_force",)

SCHEMA: dict[str, tuple[ParamSpec, ...]] = {
    "simulator": SIMULATOR_PARAMS,
    "motor_node": MOTOR_NODE_PARAMS,
    "sensor_node": SENSOR_NODE_PARAMS,
    "pid_controller": PID_CONTROLLER_PARAMS,
    "trajectory_planner": TRAJECTORY_PLANNER_PARAMS,
}

__all__ = ["NODES", "REPORTED", "ROS_BUILTIN", "SCHEMA", "URDF", "defaults", "has", "spec_of"]


def spec_of(node: str, name: str) -> ParamSpec:
    for spec in SCHEMA[node]:
        if spec.name == name:
            return spec
    raise KeyError(f"{node}.{name}")


def has(node: str, name: str) -> bool:
    return any(spec.name == name for spec in SCHEMA[node])


def defaults() -> dict[str, dict]:
    """Every node's default values (the reference scenario with the default controller)."""
    return {node: {spec.name: spec.default_value() for spec in specs} for node, specs in SCHEMA.items()}
