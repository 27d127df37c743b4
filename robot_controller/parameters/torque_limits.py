"""Each joint's URDF effort limit as a node's ``torque_max`` where its parameters leave it empty."""

from __future__ import annotations

from collections.abc import Mapping
from functools import lru_cache
from typing import Any

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.parameters.spec import per_joint

# The nodes that hold a torque limit of their own.
TORQUE_LIMITED = ("motor_node", "pid_controller", "trajectory_planner")


@lru_cache(maxsize=8)
def _urdf_effort_limits(urdf_path: str) -> tuple[tuple[str, ...], tuple[float, ...]]:
    """Each joint's name and ``<limit effort=…>`` (N·m) in the URDF at ``urdf_path`` ("": the reference arm)."""
    from robot_controller import resources
    from robot_controller.core.model import effort_limits, joint_names, load_model

    model = load_model(resources.resolve_urdf(urdf_path))
    return tuple(joint_names(model)), tuple(float(x) for x in effort_limits(model))


def torque_limit(values: Mapping[str, Any], joint_count: int) -> np.ndarray:
    """A node's ``torque_max`` per joint (N·m): as set, or each joint's URDF effort limit when it is empty."""
    if np.size(values["torque_max"]) > 0:
        return per_joint("torque_max", values["torque_max"], joint_count)
    names, limits = _urdf_effort_limits(values["urdf_path"])
    if len(limits) != joint_count:
        raise ConfigError(f"torque_max: the URDF has {len(limits)} joints, expected {joint_count}")
    unlimited = [name for name, limit in zip(names, limits, strict=True) if not np.isfinite(limit) or limit <= 0]
    if unlimited:
        raise ConfigError(f"torque_max: the URDF gives {unlimited} no effort limit; set torque_max for every joint")
    return np.array(limits)


def fill_torque_limits(params: dict[str, dict[str, Any]]) -> None:
    """Each empty ``torque_max`` written out as its node's URDF effort limits: the run's ``params.yaml`` and every
    check see the numbers in force."""
    for node in TORQUE_LIMITED:
        values = params.get(node, {})
        if "torque_max" in values and np.size(values["torque_max"]) == 0:
            joint_count = len(_urdf_effort_limits(values["urdf_path"])[0])
            try:
                values["torque_max"] = torque_limit(values, joint_count).tolist()
            except ConfigError as exc:
                raise ConfigError(f"{node}.{exc}") from None
