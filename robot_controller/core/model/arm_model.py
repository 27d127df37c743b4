"""An arm model from per-joint parameters, for when the URDF is not the arm.

The controller's model-based parts ask an arm model ``torque(q, v, a)``, ``gravity(q)``,
``acceleration(q, v, tau)``, ``predict(q, v, tau, horizon_s)``, ``mass_matrix(q)``, ``damping``,
``joint_names`` and ``effort_limit``: :class:`~robot_controller.core.model.ArmDynamics` answers
from the URDF through MuJoCo, :class:`JointArmModel` for independent revolute joints, each

    tau = I·a + b·v + f_c·sign(v) + G·cos(q)

(inertia kg·m², viscous damping N·m·s/rad, Coulomb friction N·m, gravity torque N·m with the
link horizontal at q = 0). Exact on one joint; on a chain it leaves out the coupling. The values
come from identification through the ``pid_controller`` parameters ``model_*``; any left empty
is the URDF's.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.model.arm_dynamics import step_count

# The model parameters, in the order of the regression (identification) and of the parameters.
PARAMETERS = ("inertia", "damping", "coulomb_friction", "gravity_torque")


class JointArmModel:
    """Independent revolute joints with identified (or given) inertia, damping,
    Coulomb friction and gravity torque; the same interface the controller
    uses from :class:`~robot_controller.core.model.ArmDynamics`.

    :param joint_names: the joints, in order (the URDF's)
    :param inertia: per joint, kg·m² (> 0)
    :param damping: per joint, N·m·s/rad (>= 0)
    :param coulomb_friction: per joint, N·m (>= 0)
    :param gravity_torque: per joint, N·m: gravity torque = gravity_torque·cos(q)
    :param effort_limit: per joint, N·m: forward dynamics limit the torque to it,
        as the drive does (infinite for none)
    :param source: per parameter, where its values came from (for the log), e.g.
        ``{"inertia": "parameter", "damping": "URDF"}``
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
        self.joint_units = ["rad"] * len(self.joint_names)  #: revolute joints
        n = len(self.joint_names)

        def joints(name: str, values: np.ndarray) -> np.ndarray:
            array = np.array(values, dtype=float).reshape(-1)
            if array.shape != (n,) or not np.all(np.isfinite(array)):
                raise ConfigError(f"{name}: expected {n} finite value(s), got {np.asarray(values).tolist()}")
            return array

        self.inertia = joints("inertia", inertia)
        self._damping = joints("damping", damping)
        self.coulomb_friction = joints("coulomb_friction", coulomb_friction)
        self.gravity_torque = joints("gravity_torque", gravity_torque)
        if np.any(self.inertia <= 0):
            raise ConfigError(f"inertia: must be > 0 kg·m², got {self.inertia.tolist()}")
        if np.any(self._damping < 0) or np.any(self.coulomb_friction < 0):
            raise ConfigError(
                f"damping and coulomb_friction: must be >= 0, got {self._damping.tolist()} "
                f"and {self.coulomb_friction.tolist()}"
            )
        self.effort_limit = (
            np.full(n, np.inf) if effort_limit is None else np.array(effort_limit, dtype=float).reshape(n)
        )
        self.source = dict(source or {name: "given" for name in PARAMETERS})

    @classmethod
    def over_urdf(
        cls,
        dynamics,
        *,
        inertia: np.ndarray | None = None,
        damping: np.ndarray | None = None,
        coulomb_friction: np.ndarray | None = None,
        gravity_torque: np.ndarray | None = None,
    ) -> JointArmModel:
        """The model with the given values, and the URDF's (``dynamics``, an
        :class:`~robot_controller.core.model.ArmDynamics`) for those left None:
        the inertia and gravity torque with every joint at 0 (the diagonal of
        the mass matrix; gravity's torque there, the link horizontal), the
        joint's damping and friction (``<dynamics damping friction>``).
        Joint names and effort limits are always the URDF's."""
        n = len(dynamics.joint_names)
        zero = np.zeros(n)
        dofs = dynamics.model.jnt_dofadr[:n]
        urdf = {
            "inertia": lambda: np.diag(dynamics.mass_matrix(zero)),
            "damping": lambda: np.asarray(dynamics.damping, dtype=float)[dofs],
            "coulomb_friction": lambda: dynamics.model.dof_frictionloss[dofs].copy(),
            "gravity_torque": lambda: np.asarray(dynamics.gravity(zero), dtype=float)[dofs],
        }
        given = {
            "inertia": inertia,
            "damping": damping,
            "coulomb_friction": coulomb_friction,
            "gravity_torque": gravity_torque,
        }
        values = {name: urdf[name]() if given[name] is None else given[name] for name in PARAMETERS}
        source = {name: "URDF" if given[name] is None else "parameter" for name in PARAMETERS}
        return cls(dynamics.joint_names, effort_limit=dynamics.effort_limit, source=source, **values)

    # --- the interface the controller uses ----------------------------------------------

    @property
    def damping(self) -> np.ndarray:
        """Viscous joint damping, N·m·s/rad."""
        return self._damping.copy()

    def mass_matrix(self, position: np.ndarray) -> np.ndarray:
        """Diagonal: the joints are independent."""
        return np.diag(self.inertia)

    def gravity(self, position: np.ndarray) -> np.ndarray:
        """Gravity's torque on each joint at ``position`` (rad), N·m (the torque that holds the arm there)."""
        return self.gravity_torque * np.cos(np.asarray(position, dtype=float))

    def torque(self, position: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
        """Inverse dynamics: the torque (N·m) that gives ``acceleration`` (rad/s²) at ``(position, velocity)``."""
        velocity = np.asarray(velocity, dtype=float)
        return (
            self.inertia * np.asarray(acceleration, dtype=float)
            + self._damping * velocity
            + self.coulomb_friction * np.sign(velocity)
            + self.gravity(position)
        )

    def _net(
        self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray, external_nm: np.ndarray | None = None
    ) -> np.ndarray:
        """Torque left for acceleration and friction: applied (within the effort limit) + external
        − damping − gravity."""
        torque = np.clip(np.asarray(torque, dtype=float), -self.effort_limit, self.effort_limit)
        if external_nm is not None:
            torque = torque + external_nm
        return torque - self._damping * velocity - self.gravity(position)

    def acceleration(self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray) -> np.ndarray:
        """Forward dynamics: joint acceleration (rad/s²) under ``torque`` (N·m) at ``(q, v)``.
        At rest, friction holds up to ``coulomb_friction`` (stiction)."""
        velocity = np.asarray(velocity, dtype=float)
        net = self._net(position, velocity, torque)
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
        """State ``horizon_s`` seconds ahead under constant ``torque`` (limited to
        the effort limit) and ``external_nm`` (not limited), semi-implicit
        Euler, implicit in the damping, as ``ArmDynamics.predict`` and MuJoCo's
        physics. Friction acts on each step's new velocity: it stops a joint
        within the step rather than reversing it."""
        position = np.array(position, dtype=float)
        velocity = np.array(velocity, dtype=float)
        steps = step_count(horizon_s, max_step_s)
        h = horizon_s / steps
        # Implicit damping: inertia·(v' − v)/h = net force with −damping·v' in place of −damping·v.
        effective_inertia = self.inertia + h * self._damping
        stop = self.coulomb_friction * h / effective_inertia  # the speed friction takes away in one step
        for _ in range(steps):
            free = velocity + self._net(position, velocity, torque, external_nm) * h / effective_inertia
            velocity = np.where(np.abs(free) <= stop, 0.0, free - stop * np.sign(free))
            position = position + velocity * h
        return position, velocity

    # --- for logs ---------------------------------------------------------------------

    def describe(self) -> str:
        """One line: the values in force and where each came from."""

        def values(name: str) -> str:
            return "[" + ", ".join(f"{v:.4g}" for v in getattr(self, name)) + "]"

        units = {"inertia": "kg·m²", "damping": "N·m·s/rad", "coulomb_friction": "N·m", "gravity_torque": "N·m"}
        return "arm model: " + ", ".join(
            f"{name} {values('_damping' if name == 'damping' else name)} {units[name]} ({self.source[name]})"
            for name in PARAMETERS
        )
