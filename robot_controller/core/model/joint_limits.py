"""Each joint's position and velocity limits, from the URDF: positions through MuJoCo (the ranges the simulator
enforces), speeds from the URDF's XML (MuJoCo keeps none). A limit the URDF leaves out is infinite."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.model.mujoco_model import joint_names, load_model, position_ranges


@dataclass(frozen=True)
class JointLimits:
    """Per joint, in the arm's order: position range (rad, or m for a slide) and speed limit (rad/s, m/s)."""

    joint_names: tuple[str, ...]
    lower: np.ndarray
    upper: np.ndarray
    velocity: np.ndarray

    @classmethod
    def unlimited(cls, joint_names: Sequence[str]) -> JointLimits:
        n = len(joint_names)
        return cls(tuple(joint_names), np.full(n, -np.inf), np.full(n, np.inf), np.full(n, np.inf))


def urdf_velocity_limits(urdf_path: str | Path, joint_names: Sequence[str]) -> np.ndarray:
    """Each of ``joint_names``' ``<limit velocity=…>`` in the URDF at ``urdf_path``; ``inf`` where it has none.

    :raises ConfigError: a file that is not XML, or a velocity that is not a number ≥ 0
    """
    try:
        root = ET.parse(urdf_path).getroot()
    except (ET.ParseError, OSError) as exc:
        raise ConfigError(f"urdf_path: cannot read velocity limits from {str(urdf_path)!r}: {exc}") from None
    found: dict[str, float] = {}
    for joint in root.iter("joint"):
        limit = joint.find("limit")
        text = None if limit is None else limit.get("velocity")
        if text is None:
            continue
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not value >= 0:  # NaN too
            raise ConfigError(f"urdf_path: joint {joint.get('name')!r} has velocity limit {text!r}")
        found[joint.get("name", "")] = value if value > 0 else math.inf  # 0 is urdfdom's "not given"
    return np.array([found.get(name, math.inf) for name in joint_names])


def joint_limits(urdf_path: str | Path) -> JointLimits:
    """The arm's joints and their limits, from the URDF at ``urdf_path``.

    :raises ConfigError: a URDF MuJoCo cannot load
    """
    model = load_model(urdf_path)
    names = joint_names(model)
    lower, upper = position_ranges(model).T
    return JointLimits(tuple(names), lower, upper, urdf_velocity_limits(urdf_path, names))
