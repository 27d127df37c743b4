"""An arm model from per-joint parameters (:class:`JointArmModel`), for when the URDF is not the arm, and for a
batch of arms: what the model-based parts ask of :class:`~.arm_dynamics.ArmDynamics`, for independent revolute
joints, each ``tau = I·a + b·v + f_c·sign(v) + G·cos(q)`` (q = 0 horizontal). Exact on one joint; on a chain it
leaves out the coupling. Its arrays broadcast: ``(batch, joints)`` states step many arms at once.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.model.arm_dynamics import step_count
from robot_controller.core.model.friction import coulomb_torque

# The model parameters, in the order of the regression (identification) and of the parameters.
PARAMETERS = ("inertia", "damping", "coulomb_friction", "gravity_torque")
UNITS = {"inertia": "kg·m²", "damping": "N·m·s/rad", "coulomb_friction": "N·m", "gravity_torque": "N·m"}


class JointArmModel:
    """Independent revolute joints with identified (or given) inertia, damping (>= 0), Coulomb friction (>= 0)
    and gravity torque (``gravity_torque``·cos q), one value per joint of ``joint_names``.

    :param effort_limit: per joint, N·m: ``acceleration`` and ``predict`` limit the torque to it, as the drive
        does (infinite for none)
    :param source: per parameter, where its values came from (for the log), e.g. ``{"inertia": "parameter"}``
    """

    def __init__(
        self,
        joint_names: Sequence[str],
        inertia: np.ndarray,
        damping: np.ndarray,
        coulomb_friction: np.ndarray,
        gravity_torque: np.ndarray,
        effort_limit: np.ndarray | None = None,
        source: dict[str, str] | None = None,
    ) -> None:
        self.joint_names = list(joint_names)
        self.joint_units = ["rad"] * len(self.joint_names)
        n = len(self.joint_names)

        def joints(name: str, values: np.ndarray) -> np.ndarray:
            array = np.array(values, dtype=float).reshape(-1)
            if array.shape != (n,) or not np.all(np.isfinite(array)):
                raise ConfigError(f"{name}: expected {n} finite value(s), got {np.asarray(values).tolist()}")
            return array

        self.inertia = joints("inertia", inertia)
        self.damping = joints("damping", damping)
        self.coulomb_friction = joints("coulomb_friction", coulomb_friction)
        self.gravity_torque = joints("gravity_torque", gravity_torque)
        if np.any(self.inertia <= 0):
            raise ConfigError(f"inertia: must be > 0 kg·m², got {self.inertia.tolist()}")
        if np.any(self.damping < 0) or np.any(self.coulomb_friction < 0):
            raise ConfigError(
                f"damping and coulomb_friction: must be >= 0, got {self.damping.tolist()} "
                f"and {self.coulomb_friction.tolist()}"
            )
        self.effort_limit = (
            np.full(n, np.inf) if effort_limit is None else np.array(effort_limit, dtype=float).reshape(n)
        )
        self.source = dict(source or {name: "given" for name in PARAMETERS})

    @classmethod
    def over_urdf(cls, dynamics, **given: np.ndarray | None) -> JointArmModel:
        """The model with the values ``given`` (by :data:`PARAMETERS`' names), the URDF's (``dynamics``, an
        :class:`~robot_controller.core.model.ArmDynamics`) for those left out or None: the inertia and gravity
        torque with every joint at 0 (the diagonal of the mass matrix; the link horizontal), the joint's damping
        and friction. Joint names and effort limits are always the URDF's."""
        n = len(dynamics.joint_names)
        zero = np.zeros(n)
        dofs = dynamics.model.jnt_dofadr[:n]
        urdf = {
            "inertia": lambda: np.diag(dynamics.mass_matrix(zero)),
            "damping": lambda: dynamics.damping[dofs],
            "coulomb_friction": lambda: dynamics.model.dof_frictionloss[dofs].copy(),
            "gravity_torque": lambda: dynamics.gravity(zero)[dofs],
        }
        values = {name: urdf[name]() if given.get(name) is None else given[name] for name in PARAMETERS}
        source = {name: "URDF" if given.get(name) is None else "parameter" for name in PARAMETERS}
        return cls(dynamics.joint_names, effort_limit=dynamics.effort_limit, source=source, **values)

    def mass_matrix(self, position: np.ndarray) -> np.ndarray:
        """Diagonal: the joints are independent."""
        return np.diag(self.inertia)

    def gravity(self, position: np.ndarray) -> np.ndarray:
        """The torque (N·m) that holds the arm at ``position`` (rad)."""
        return self.gravity_torque * np.cos(position)

    def torque(self, position: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
        """Inverse dynamics: the torque (N·m) that gives ``acceleration`` (rad/s²) at ``(position, velocity)``."""
        velocity = np.asarray(velocity, dtype=float)
        return (
            self.inertia * np.asarray(acceleration, dtype=float)
            + self.damping * velocity
            + coulomb_torque(self.coulomb_friction, velocity)
            + self.gravity(position)
        )

    def acceleration(self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray) -> np.ndarray:
        """Forward dynamics: joint acceleration (rad/s²) under ``torque`` (N·m, within the effort limit) at
        ``(q, v)``. At rest, friction holds up to ``coulomb_friction`` (stiction)."""
        velocity = np.asarray(velocity, dtype=float)
        net = np.clip(torque, -self.effort_limit, self.effort_limit) - self.damping * velocity - self.gravity(position)
        friction = np.where(
            velocity != 0.0,
            self.coulomb_friction * np.sign(velocity),
            np.clip(net, -self.coulomb_friction, self.coulomb_friction),
        )
        return (net - friction) / self.inertia

    def predict(
        self,
        position: np.ndarray,
        velocity: np.ndarray,
        torque: np.ndarray,
        horizon_s: float,
        max_step_s: float = 0.002,
        external_nm: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """State ``horizon_s`` seconds ahead under constant ``torque`` (limited to the effort limit) and
        ``external_nm`` (not limited), in equal steps of at most ``max_step_s`` (:meth:`steps`)."""
        force = np.clip(torque, -self.effort_limit, self.effort_limit)
        if external_nm is not None:
            force = force + external_nm
        count = step_count(horizon_s, max_step_s)
        return self.steps(np.asarray(position, float), np.asarray(velocity, float), force, horizon_s / count, count)

    def steps(
        self, position: np.ndarray, velocity: np.ndarray, force: np.ndarray, h: float, count: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """``count`` semi-implicit Euler steps of ``h`` s under ``force`` (N·m), implicit in the damping as
        MuJoCo's physics: ``I·(v' − v)/h = force − b·v' − G·cos q``. Friction acts on each step's new velocity:
        it stops a joint within the step rather than reversing it."""
        damped = self.inertia + h * self.damping
        stop = self.coulomb_friction * h / damped if np.any(self.coulomb_friction) else None
        for _ in range(count):
            velocity = (velocity * self.inertia + h * (force - self.gravity_torque * np.cos(position))) / damped
            if stop is not None:
                velocity = np.where(np.abs(velocity) <= stop, 0.0, velocity - stop * np.sign(velocity))
            position = position + h * velocity
        return position, velocity

    def transition(
        self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray, horizon_s: float, max_step_s: float
    ) -> np.ndarray:
        """Per joint, how ``horizon_s`` of :meth:`predict`'s steps move ``[q, v]`` (joints × 2 × 2): one step's slopes
        at ``(q, v)`` (none where friction stops the joint within it) carried over the horizon's steps."""
        count = step_count(horizon_s, max_step_s)
        h = horizon_s / count
        damped = self.inertia + h * self.damping
        q, v = np.asarray(position, float), np.asarray(velocity, float)
        by_q = h * self.gravity_torque * np.sin(q) / damped
        by_v = np.broadcast_to(self.inertia / damped, by_q.shape)
        if np.any(self.coulomb_friction):
            force = np.clip(torque, -self.effort_limit, self.effort_limit)
            free = (v * self.inertia + h * (force - self.gravity_torque * np.cos(q))) / damped
            moving = np.abs(free) > self.coulomb_friction * h / damped
            by_q, by_v = by_q * moving, by_v * moving
        step = np.empty((by_q.size, 2, 2))
        step[:, 0, 0], step[:, 0, 1] = 1.0 + h * by_q.ravel(), h * by_v.ravel()
        step[:, 1, 0], step[:, 1, 1] = by_q.ravel(), by_v.ravel()
        return np.linalg.matrix_power(step, count)

    def describe(self) -> str:
        """One line: the values in force and where each came from."""
        return "arm model: " + ", ".join(
            f"{name} [{', '.join(f'{v:.4g}' for v in getattr(self, name))}] {UNITS[name]} ({self.source[name]})"
            for name in PARAMETERS
        )
