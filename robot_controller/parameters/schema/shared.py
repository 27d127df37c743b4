"""Parameter specs more than one node declares: the URDF, the arm model's values, a torque limit, the sim's clock."""

from __future__ import annotations

from collections.abc import Mapping
from enum import Enum
from typing import Any

from robot_controller.parameters.spec import ParamSpec

#: the range of a parameter that must be above zero: ``**POSITIVE``
POSITIVE = {"minimum": 0.0, "exclusive_minimum": True}
#: a timeout or limit that protects the arm, set only by the run's configuration: ``**SAFETY``
SAFETY = {"read_only": True, "safety": True}


def enum_values(enum: type[Enum]) -> tuple[str, ...]:
    """The choices of a string parameter that names one of ``enum``'s members."""
    return tuple(member.value for member in enum)


URDF = ParamSpec(
    "urdf_path",
    str,
    "",
    "robot description (URDF file); empty means the package's reference arm (description/one_dof_arm.urdf)",
    read_only=True,
)


def arm_model_specs(lead: str = "arm model: ") -> tuple[ParamSpec, ...]:
    """The arm model's per-joint values (empty: the URDF's), for the controller and, led by ``lead``,
    for the planner that checks its trajectory against the same model."""
    common = {"per_joint": True, "allow_empty": True, "read_only": True}
    # fmt: off
    return (
        ParamSpec("model_inertia", float, [], lead + "each joint's inertia about its axis, kg·m² (on a chain: at q = 0, the coupled model's own plus a rotor's; empty: the URDF's)", **POSITIVE, **common),
        ParamSpec("model_damping", float, [], lead + "each joint's viscous damping, N·m·s/rad (empty: the URDF's)", minimum=0.0, **common),
        ParamSpec("model_coulomb_friction", float, [], lead + "each joint's Coulomb (dry) friction, N·m (empty: the URDF's)", minimum=0.0, **common),
        ParamSpec("model_gravity_torque", float, [], lead + "gravity's torque on each joint with its link horizontal (m·g·l_c), N·m; the torque is this times cos(q), q = 0 horizontal as in the reference arm (one joint only: a chain's gravity is its links'; empty: the URDF's)", **common),
        ParamSpec("model_payload", float, [], lead + "a load on the last joint's link beyond the URDF: [mass_kg, x_m, y_m, z_m], a point mass at that point of the link's frame (empty: none; identify fits it on a chain of joints)", length=4, allow_empty=True, read_only=True),
    )
    # fmt: on


#: The name of the ROS parameter that puts a node on the sim's clock, where the world waits for each command (``run``
#: sets it for the paced world and ``--sim-time``); users' parameter files set it by this name, which stays.
WORLD_WAITS = "lockstep"


def world_waits_spec(description: str) -> ParamSpec:
    """The read-only switch to the sim's clock (:data:`WORLD_WAITS`); ``description``: what it changes in a node."""
    return ParamSpec(WORLD_WAITS, bool, False, description, read_only=True)


def world_waits(values: Mapping[str, Any]) -> bool:
    """Whether a node's parameter ``values`` put it on the sim's clock, where the world waits for each command."""
    return bool(values.get(WORLD_WAITS, False))


def torque_max_spec(description: str, safety: bool = False) -> ParamSpec:
    """A node's torque limit per joint; empty (the default): each joint's URDF effort limit, its bound
    (``safety``: the drive's, read-only)."""
    return ParamSpec(
        "torque_max",
        float,
        [],
        description + ", N·m (one per joint, or one for all; empty: each joint's URDF effort limit)",
        per_joint=True,
        allow_empty=True,
        **POSITIVE,
        **(SAFETY if safety else {}),
    )
