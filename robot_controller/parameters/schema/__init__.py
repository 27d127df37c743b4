"""Every parameter of every node, one entry each: type, default, description, accepted range or
choices, per joint or not, read-only or not (in the spirit of generate_parameter_library). The nodes
declare their parameters from here, ``robot-controller params`` prints them, and ``params --yaml``
writes the defaults as a ROS 2 parameter file.

One module per node holds its entries; ``shared`` holds the specs several nodes declare; ``nodes``
gathers them. Rates have a floor and a ceiling this stack can keep: a rate beyond it starves the
loop, one below it leaves the watchdog with nothing to watch.
"""

from robot_controller.parameters.schema.nodes import NODES, REPORTED, ROS_BUILTIN, SCHEMA, defaults, has, spec_of
from robot_controller.parameters.schema.shared import URDF

__all__ = ["NODES", "REPORTED", "ROS_BUILTIN", "SCHEMA", "URDF", "defaults", "has", "spec_of"]
