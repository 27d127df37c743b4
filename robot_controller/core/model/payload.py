"""A payload the arm carries and its URDF does not describe: a point mass on the link of its last joint, ``[mass_kg,
x_m, y_m, z_m]`` in that link's frame (the simulator's ``payload``, the controller's ``model_payload``). MuJoCo carries
it as a small sphere welded to the link, so gravity, inertia and the coupling between joints come with it."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import mujoco
import numpy as np

from robot_controller.core.errors import ConfigError

BODY_NAME = "robot_controller_payload"
#: m, the payload's size: a solid sphere this wide (its own inertia, 2/5·m·r², is small beside the arm's)
RADIUS_M = 0.02
#: kg, a payload heavier than this is taken for a typing error
MAX_MASS_KG = 100.0
#: m, a centre further than this from the link's frame is taken for a typing error
MAX_OFFSET_M = 2.0
#: m, how far from the last link's origin a rated payload's centre may sit (a tool at the flange)
RATED_REACH_M = 0.1


@dataclass(frozen=True)
class Payload:
    """:param mass_kg: kg (>= 0)
    :param com_m: its centre in the frame of the last joint's link, m (x, y, z)
    """

    mass_kg: float
    com_m: tuple[float, float, float]

    @classmethod
    def from_values(cls, name: str, values: Sequence[float] | None) -> Payload | None:
        """From a parameter ``[mass_kg, x_m, y_m, z_m]``; None for an empty one."""
        if values is None or len(values) == 0:
            return None
        array = np.asarray(values, dtype=float).reshape(-1)
        if array.size != 4 or not np.all(np.isfinite(array)):
            raise ConfigError(f"{name}: expected [mass_kg, x_m, y_m, z_m], four finite numbers, got {list(values)}")
        if not 0.0 <= array[0] <= MAX_MASS_KG:
            raise ConfigError(f"{name}: mass {array[0]:g} kg is not within [0, {MAX_MASS_KG:g}] kg")
        if np.linalg.norm(array[1:]) > MAX_OFFSET_M:
            raise ConfigError(f"{name}: its centre {array[1:].tolist()} m is over {MAX_OFFSET_M:g} m from the link")
        return cls(float(array[0]), (float(array[1]), float(array[2]), float(array[3])))

    def as_values(self) -> list[float]:
        return [self.mass_kg, *self.com_m]

    @property
    def inertia_kgm2(self) -> float:
        """The sphere's own inertia about its centre, each axis."""
        return 0.4 * self.mass_kg * RADIUS_M**2


def carrying_link(model: mujoco.MjModel) -> str:
    """The name of the last joint's link: where a payload sits."""
    return model.body(int(model.jnt_bodyid[model.njnt - 1])).name


def add_to(spec: mujoco.MjSpec, carrier: str, payload: Payload) -> None:
    """Weld ``payload`` to the body ``carrier`` of ``spec`` (before it is compiled)."""
    body = spec.body(carrier).add_body()
    body.name = BODY_NAME
    body.pos = list(payload.com_m)
    body.ipos = [0.0, 0.0, 0.0]  # its centre at its frame's origin (URDF import would otherwise offset it again)
    body.mass = max(payload.mass_kg, 1e-9)  # MuJoCo refuses a massless body with inertia; 1 µg is nothing
    body.inertia = [max(payload.inertia_kgm2, 1e-12)] * 3
    body.explicitinertial = True


def set_payload(model: mujoco.MjModel, payload: Payload) -> None:
    """Give a compiled model's payload body (see :func:`add_to`) another mass and place: the dynamics (``mj_forward``,
    ``mj_inverse``) read these each call, so a fit can try payloads without compiling the arm again."""
    body = model.body(BODY_NAME)
    body_id = body.id
    model.body_pos[body_id] = payload.com_m
    model.body_ipos[body_id] = 0.0
    model.body_mass[body_id] = max(payload.mass_kg, 1e-9)
    model.body_inertia[body_id] = max(payload.inertia_kgm2, 1e-12)


def reach_lever_m(model: mujoco.MjModel, position: np.ndarray) -> np.ndarray:
    """Per joint at ``position``, m per unit of its speed: the most a point within RATED_REACH_M of the last link's
    origin moves (|origin's speed| + RATED_REACH_M·|turn rate|)."""
    n, data = len(position), mujoco.MjData(model)
    data.qpos[:n] = position
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    body = int(model.jnt_bodyid[model.njnt - 1])
    moves, turns = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    mujoco.mj_jac(model, data, moves, turns, data.xpos[body], body)
    return (np.linalg.norm(moves, axis=0) + RATED_REACH_M * np.linalg.norm(turns, axis=0))[:n]


def torque_bound(model: mujoco.MjModel, mass_kg: float, position: np.ndarray) -> np.ndarray:
    """Per joint, the most gravity torque (N·m; N on a slide) a point mass of ``mass_kg`` within RATED_REACH_M
    of the last link's origin puts on each joint at ``position``: m·g·:func:`reach_lever_m`."""
    return mass_kg * float(np.linalg.norm(model.opt.gravity)) * reach_lever_m(model, position)


def inertia_bound(model: mujoco.MjModel, mass_kg: float, position: np.ndarray) -> np.ndarray:
    """Per joint, the most inertia (kg·m²; kg on a slide) such a point mass adds at ``position``: m·lever²."""
    return mass_kg * reach_lever_m(model, position) ** 2
