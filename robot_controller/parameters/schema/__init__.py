"""Every parameter of every node, one entry each (type, default, description, range or choices, per joint, read-only),
as in generate_parameter_library: the nodes declare from here, ``params`` prints them. One module per node; ``shared``
holds specs several declare. Rates have a floor and a ceiling: beyond it the loop starves, below it the watchdog has
nothing to watch."""

from robot_controller.parameters.schema.nodes import (
    LOOP_WIDE,
    NODES,
    REPORTED,
    ROS_BUILTIN,
    SCHEMA,
    defaults,
    has,
    node_defaults,
    spec_of,
)
from robot_controller.parameters.schema.shared import URDF, WORLD_WAITS, world_waits

__all__ = [
    "LOOP_WIDE",
    "NODES",
    "REPORTED",
    "ROS_BUILTIN",
    "SCHEMA",
    "URDF",
    "WORLD_WAITS",
    "defaults",
    "has",
    "node_defaults",
    "spec_of",
    "world_waits",
]
