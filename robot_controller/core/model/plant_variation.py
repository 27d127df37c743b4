"""The plant the controller does not know: joint friction, damping, rotor inertia, link masses and a payload the
simulated arm has and its URDF (so the controller's model) lacks, applied to the plant's compiled model alone. Each
is added to what the URDF says, or for the masses multiplies it; the defaults change nothing."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import mujoco
import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.model.friction import make_friction_stick
from robot_controller.core.model.payload import BODY_NAME as PAYLOAD_BODY
from robot_controller.core.model.payload import Payload

#: The simulator parameters read here; ``payload`` is the older [mass_kg, x_m, y_m, z_m] form of the last two.
KEYS = (
    "joint_friction_nm",
    "joint_damping_nms",
    "armature_kgm2",
    "link_mass_scale",
    "payload",
    "payload_kg",
    "payload_offset_m",
)


@dataclass(frozen=True)
class PlantVariation:
    """Per joint: one value for every joint, or one per joint."""

    joint_friction_nm: tuple[float, ...] = (0.0,)  #: Coulomb friction, N·m (MuJoCo's ``frictionloss``)
    joint_damping_nms: tuple[float, ...] = (0.0,)  #: viscous, N·m·s/rad
    armature_kgm2: tuple[float, ...] = (0.0,)  #: rotor inertia reflected through the gears, kg·m²
    #: each link's mass and inertia times this, the links a joint moves taking its value (a hand, the last's)
    link_mass_scale: tuple[float, ...] = (1.0,)
    payload: Payload | None = None  #: a point mass on the last joint's link

    def __post_init__(self) -> None:
        for name in ("joint_friction_nm", "joint_damping_nms", "armature_kgm2"):
            _checked(name, getattr(self, name), positive=False)
        _checked("link_mass_scale", self.link_mass_scale, positive=True)

    @classmethod
    def from_params(cls, params: Mapping[str, Any], prefix: str = "") -> PlantVariation:
        """From the simulator's parameters (a key left out keeps its default); ``prefix`` goes before every key
        a refusal names (``"simulator."``)."""
        values = {name: _tuple(prefix + name, params[name]) for name in KEYS[:4] if name in params}
        try:
            variation = cls(**values, payload=_payload(params, prefix))
        except ConfigError as exc:
            raise ConfigError(f"{prefix}{exc}") from None
        return variation

    @property
    def nominal(self) -> bool:
        """Whether it changes nothing: the plant is its URDF."""
        return self == PlantVariation()

    def per_joint(self, joint_count: int) -> dict[str, np.ndarray]:
        """Each per-joint value as one number per joint; ``ConfigError`` naming the key on a wrong length."""
        out = {}
        for name in KEYS[:4]:
            values = np.asarray(getattr(self, name), dtype=float)
            if values.size not in (1, joint_count):
                raise ConfigError(f"{name}: expected 1 or {joint_count} values (one per joint), got {values.size}")
            out[name] = np.broadcast_to(values, (joint_count,)).copy()
        return out

    def apply(self, model: mujoco.MjModel) -> None:
        """Change the compiled ``model`` in place (its payload is a body ``load_model`` adds before compiling)."""
        count = model.njnt
        values = self.per_joint(count)
        dofs = model.jnt_dofadr[:count]
        model.dof_frictionloss[dofs] += values["joint_friction_nm"]
        make_friction_stick(model, dofs[values["joint_friction_nm"] > 0], model.opt.timestep)
        model.dof_damping[dofs] += values["joint_damping_nms"]
        model.dof_armature[dofs] += values["armature_kgm2"]
        scale = _body_scale(model, values["link_mass_scale"])
        model.body_mass[:] *= scale
        model.body_inertia[:] *= scale[:, None]
        # The quantities MuJoCo derives from masses and armature at compile time (the constraint solver's
        # weights among them, which friction's stiction uses): computed again.
        mujoco.mj_setConst(model, mujoco.MjData(model))

    def describe(self) -> str:
        """What differs from the URDF, in one line (``""`` when nothing does)."""
        parts = [
            f"{label} {_listed(getattr(self, name))} {unit}"
            for name, label, unit, none in (
                ("joint_friction_nm", "joint friction", "N·m", 0.0),
                ("joint_damping_nms", "damping", "N·m·s/rad", 0.0),
                ("armature_kgm2", "armature", "kg·m²", 0.0),
                ("link_mass_scale", "link masses ×", "", 1.0),
            )
            if any(v != none for v in getattr(self, name))
        ]
        if self.payload is not None and self.payload.mass_kg > 0:
            parts.append(f"payload {self.payload.mass_kg:g} kg at {list(self.payload.com_m)} m")
        return ", ".join(part.rstrip() for part in parts)


def _tuple(name: str, value: Any) -> tuple[float, ...]:
    array = np.atleast_1d(np.asarray(value, dtype=float)).reshape(-1)
    if array.size == 0:
        raise ConfigError(f"{name}: expected a number or one per joint, got none")
    return tuple(float(v) for v in array)


def _checked(name: str, values: Sequence[float], *, positive: bool) -> None:
    array = np.asarray(values, dtype=float)
    if array.size == 0:
        raise ConfigError(f"{name}: expected a number or one per joint, got none")
    if not np.all(np.isfinite(array)):
        raise ConfigError(f"{name}: must be finite, got {list(values)}")
    if positive and np.any(array <= 0):
        raise ConfigError(f"{name}: must be > 0 (a factor on each link's mass), got {list(values)}")
    if not positive and np.any(array < 0):
        raise ConfigError(f"{name}: must be >= 0 (it is added to the URDF's own), got {list(values)}")


def _payload(params: Mapping[str, Any], prefix: str) -> Payload | None:
    old = params.get("payload") or []
    mass = float(params.get("payload_kg", 0.0))
    offset = list(params.get("payload_offset_m", [0.0, 0.0, 0.0]))
    if len(old) > 0:
        if mass != 0.0 or any(v != 0.0 for v in offset):
            raise ConfigError(
                f"{prefix}payload_kg: set either payload [mass_kg, x_m, y_m, z_m] or payload_kg with "
                f"payload_offset_m, not both (payload is {list(old)}, payload_kg {mass:g}, payload_offset_m {offset})"
            )
        return Payload.from_values(prefix + "payload", old)
    if len(offset) != 3:
        raise ConfigError(f"{prefix}payload_offset_m: expected [x_m, y_m, z_m], got {offset}")
    if not np.isfinite(mass) or mass < 0:
        raise ConfigError(f"{prefix}payload_kg: must be a finite mass >= 0, got {mass}")
    if mass == 0.0:
        return None  # an offset without a mass is no load
    return Payload.from_values(f"{prefix}payload_kg, {prefix}payload_offset_m", [mass, *offset])


def _body_scale(model: mujoco.MjModel, per_joint: np.ndarray) -> np.ndarray:
    """Each body's mass factor: that of the nearest joint on its way to the world (the joint that moves it);
    1 for a body no joint moves (the base: nothing of it moves) and for the payload (it has its own mass)."""
    scale = np.ones(model.nbody)
    payload = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, PAYLOAD_BODY)
    for body in range(1, model.nbody):
        if body == payload:
            continue
        carrier = body
        while carrier > 0 and model.body_jntnum[carrier] == 0:
            carrier = model.body_parentid[carrier]
        if carrier > 0:
            scale[body] = per_joint[model.body_jntadr[carrier]]
    return scale


def _listed(values: tuple[float, ...]) -> str:
    return f"{values[0]:g}" if len(values) == 1 else "[" + ", ".join(f"{v:g}" for v in values) + "]"
