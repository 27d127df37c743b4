"""The URDF compiled into a MuJoCo model as it is (``MjSpec.from_file``: no second, hand-written model to drift
from the robot description), for the plant and the controller's model alike, and what the stack reads from it."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from robot_controller.core.errors import ConfigError, TimingError
from robot_controller.core.model.payload import Payload, carrying_link
from robot_controller.core.model.payload import add_to as add_payload


def load_model(
    urdf_path: str | Path, physics_dt: float | None = None, payload: Payload | None = None
) -> mujoco.MjModel:
    """Compile a URDF into a MuJoCo model with one 1-DoF hinge or slide per actuated joint,
    carrying ``payload`` on its last joint's link if one is given."""
    path = Path(urdf_path)
    if not path.is_file():
        raise ConfigError(f"urdf_path: no such file {str(path)!r}")
    try:
        spec = mujoco.MjSpec.from_file(str(path))
        model = spec.compile()
        if payload is not None:
            add_payload(spec, carrying_link(model), payload)
            model = spec.compile()
    except Exception as exc:  # MuJoCo raises plain ValueError with its parser's text
        raise ConfigError(f"urdf_path: MuJoCo could not load {str(path)!r}: {exc}") from exc
    if physics_dt is not None:
        if not np.isfinite(physics_dt) or physics_dt <= 0:
            raise ConfigError(f"physics_dt: must be > 0, got {physics_dt}")
        model.opt.timestep = physics_dt
    if model.nq != model.nv or model.njnt != model.nv:
        raise ConfigError("urdf_path: only chains of revolute/prismatic joints are supported (no floating base)")
    if not can_collide(model):
        # Nothing could touch anything: MuJoCo's collision pass would find nothing, every step.
        model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
    return model


def can_collide(model: mujoco.MjModel) -> bool:
    """Whether any contact is possible in ``model``: an explicit contact pair, a flex, or
    two geoms (or one with itself) whose type and affinity bits meet. Without one (the
    reference arm's only geom is visual), disabling contacts changes no number: it skips
    a collision pass that finds nothing (about 10 % of a one-joint step)."""
    if model.npair > 0 or model.nflex > 0:
        return True
    return bool(np.any(np.bitwise_and.outer(model.geom_contype, model.geom_conaffinity)))


def joint_names(model: mujoco.MjModel) -> list[str]:
    return [model.joint(i).name for i in range(model.njnt)]


def joint_units(model: mujoco.MjModel) -> list[str]:
    """Each joint's position unit: ``"m"`` for a slide (a URDF ``prismatic`` joint), else ``"rad"``."""
    return ["m" if kind == mujoco.mjtJoint.mjJNT_SLIDE else "rad" for kind in model.jnt_type[: model.njnt]]


def position_ranges(model: mujoco.MjModel) -> np.ndarray:
    """Each joint's position range, (joints, 2): lower, upper (rad, or m on a slide); ±inf where the URDF sets none."""
    n = model.njnt
    return np.where(model.jnt_limited[:n, None].astype(bool), model.jnt_range[:n], [-np.inf, np.inf])


def steps_per_period(physics_dt: float, period_s: float) -> int:
    """Whole number of physics steps in one period; refuse ratios that are not whole."""
    ratio = period_s / physics_dt
    n = int(round(ratio))
    if n < 1 or abs(ratio - n) > 1e-6 * max(1.0, ratio):
        raise TimingError(
            f"period {period_s} s is not a whole number of physics steps of {physics_dt} s (ratio {ratio:.6g})"
        )
    return n


def effort_limits(model: mujoco.MjModel) -> np.ndarray:
    """Each actuated joint's effort limit from the URDF (``<limit effort=…>``), N·m
    (or N); infinite where the URDF gives none."""
    count = len(joint_names(model))
    low, high = model.jnt_actfrcrange[:count, 0], model.jnt_actfrcrange[:count, 1]
    limited = model.jnt_actfrclimited[:count].astype(bool) & (high > 0)
    return np.where(limited, np.minimum(np.abs(low), high), np.inf)
