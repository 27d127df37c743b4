"""The arm's multibody dynamics for the controller (:class:`ArmDynamics`), from the same URDF as the plant on a
private ``MjData``: the arm model every model-based part asks (:class:`~.arm_model.JointArmModel` answers the same
questions for independent joints)."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.model.friction import coulomb_torque, make_friction_stick
from robot_controller.core.model.mujoco_model import effort_limits, joint_names, joint_units, load_model
from robot_controller.core.model.payload import Payload

#: A joint whose damping over one plant step exceeds this share of its inertia has the step inverted.
STIFF_DAMPING_SHARE = 0.01
#: rad/s², the push whose effect :meth:`ArmDynamics.transition` differences: far above the solver's precision
PUSH = 0.1


def step_count(horizon_s: float, max_step_s: float) -> int:
    """Whole steps of at most ``max_step_s`` in ``horizon_s`` (a rounding error does not add one)."""
    return max(1, math.ceil(horizon_s / max_step_s - 1e-9))


def matrix_power(a: np.ndarray, k: int) -> np.ndarray:
    """``np.linalg.matrix_power(a, k)`` (``k >= 1``): the same products in the same order, without its checks."""
    if k == 3:
        return a.dot(a).dot(a)
    power = result = None
    while k > 0:
        power = a if power is None else power.dot(power)
        k, bit = divmod(k, 2)
        if bit:
            result = power if result is None else result.dot(power)
    return result


class ArmDynamics:
    """The arm's coupled dynamics. ``torque(q, v, a)``: M(q)·a + Coriolis + damping·v + gravity (``mj_inverse``), plus
    dry friction given over the URDF's (:func:`~.friction.coulomb_torque`),
    over one step of the plant's integrator (``step_s``) wherever a joint's damping acts within a step (step·D over
    ``STIFF_DAMPING_SHARE`` of its inertia: implicit in damping, such a wrist takes (M + step·D)·a), in continuous
    time elsewhere. ``predict`` steps the arm as the plant does (``mj_step``: the same numbers), ``step_jacobian``
    linearises one such step (``mjd_transitionFD``)."""

    def __init__(self, urdf_path: str | Path, payload: Payload | None = None, step_s: float | None = None) -> None:
        self.model = load_model(urdf_path, payload=payload)
        self.payload = payload
        self._data = mujoco.MjData(self.model)
        self.joint_names = joint_names(self.model)
        self.joint_units = joint_units(self.model)  #: "rad" or "m" per joint
        self.effort_limit = effort_limits(self.model)
        self._effort_low = -self.effort_limit
        # Views into the private MjData and the model's options, kept: the controller asks several
        # times a tick, and each lookup through the bindings costs as much as a small array operation.
        d = self._data
        self._qpos, self._qvel, self._qacc = d.qpos, d.qvel, d.qacc
        self._qfrc_applied, self._qfrc_inverse = d.qfrc_applied, d.qfrc_inverse
        self._option = self.model.opt
        self._plant_step_s = step_s
        self._choose_inverse()
        self.adjustments: dict[str, np.ndarray] = {}  #: per-joint values set over the URDF's (:meth:`adjusted`)
        #: kg·m² per joint, the armature the controller learnt at run time and holds in ``model.dof_armature`` on top of
        #: the model's own (the inertia adaptation's): designs take it away, so gains are designed on the nominal model
        self.learnt_armature = np.zeros(len(self.joint_names))
        #: N·m per joint, the dry friction given over the URDF's (:meth:`adjusted`), which sticks as a real arm's does
        #: and ``torque`` carries itself (:func:`~.friction.coulomb_torque`); None: the URDF's own, MuJoCo's soft
        #: friction as the simulator has it
        self.coulomb_friction: np.ndarray | None = None

    def _choose_inverse(self) -> None:
        """Invert the plant's step where a joint's damping acts within it, else continuous time."""
        n, step_s = len(self.joint_names), self._plant_step_s
        damped = step_s is not None and np.any(
            step_s * self.model.dof_damping[:n] > STIFF_DAMPING_SHARE * np.diag(self.mass_matrix(np.zeros(n)))
        )
        self.step_s = step_s if damped else None  #: s, the plant's step ``torque`` inverts (None: continuous time)
        #: whether a push's effect over a horizon is the model's own (damped or dry friction), not a free mass's
        self.resists_within_step = damped or bool(np.any(self.model.dof_frictionloss[:n] > 0))
        flag = int(mujoco.mjtEnableBit.mjENBL_INVDISCRETE)
        self.model.opt.enableflags = (
            (self.model.opt.enableflags | flag) if damped else (self.model.opt.enableflags & ~flag)
        )

    def torque(self, position: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
        self._qpos[:] = position
        self._qvel[:] = velocity
        self._qacc[:] = acceleration
        if self.step_s is not None:
            self._option.timestep = self.step_s
        friction = self.coulomb_friction
        if friction is None:
            mujoco.mj_inverse(self.model, self._data)
            return self._qfrc_inverse.copy()
        frictionloss = self.model.dof_frictionloss  # (the forward prediction's: out of the inverse for the call)
        frictionloss[self._dofs] = 0.0
        mujoco.mj_inverse(self.model, self._data)
        frictionloss[self._dofs] = friction
        return self._qfrc_inverse + coulomb_torque(friction, velocity)

    def gravity(self, position: np.ndarray) -> np.ndarray:
        zero = np.zeros(self.model.nv)
        return self.torque(position, zero, zero)

    def acceleration(self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray) -> np.ndarray:
        """Forward dynamics under ``torque`` (within the effort limit, as the plant applies it), rad/s²."""
        self._load(position, velocity, torque, None)
        mujoco.mj_forward(self.model, self._data)
        self._qfrc_applied.fill(0.0)
        return self._qacc.copy()

    def _load(
        self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray, external_nm: np.ndarray | None
    ) -> None:
        """The private state at ``(q, v)`` with ``torque`` (within the effort limit) and ``external_nm`` applied."""
        self._qpos[:] = position
        self._qvel[:] = velocity
        applied = np.minimum(np.maximum(torque, self._effort_low), self.effort_limit)  # np.clip, without its wrapper
        # (Summed here, then written: a ufunc writing into MuJoCo's array costs more than the copy.)
        self._qfrc_applied[:] = applied if external_nm is None else applied + external_nm

    def predict(
        self,
        position: np.ndarray,
        velocity: np.ndarray,
        torque: np.ndarray,
        horizon_s: float,
        max_step_s: float = 0.002,
        external_nm: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """State ``horizon_s`` s ahead under constant ``torque`` (within the effort limit) and ``external_nm`` (not
        limited), in equal steps of at most ``max_step_s``: MuJoCo's own, implicit in the damping as the plant's,
        so the filter's model has no h·D/M bias in acceleration."""
        steps = step_count(horizon_s, max_step_s)
        self._option.timestep = horizon_s / steps
        self._load(position, velocity, torque, external_nm)
        mujoco.mj_step(self.model, self._data, steps)
        self._qfrc_applied.fill(0.0)
        return self._qpos.copy(), self._qvel.copy()

    def step_jacobian(
        self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray, step_s: float
    ) -> np.ndarray:
        """How one step of ``step_s`` moves the state ``[q; v]`` (2n × 2n), by MuJoCo's finite differences."""
        n = self.model.nv
        self._option.timestep = step_s
        self._load(position, velocity, torque, None)
        jacobian = np.zeros((2 * n, 2 * n))
        mujoco.mjd_transitionFD(self.model, self._data, 1e-6, 0, jacobian, None, None, None)
        self._qfrc_applied.fill(0.0)
        return jacobian

    def transition(
        self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray, horizon_s: float, max_step_s: float
    ) -> np.ndarray:
        """How ``horizon_s`` of :meth:`predict`'s steps move ``[q; v]`` (2n × 2n): one step's slopes carried over
        the steps. Where damping or dry friction resists within a step, 2n × 3n: also how a push ``M(q)·α`` moves
        it per rad/s² on each joint (a free mass's ``[h²/2; h]`` would overstate it), so an observer's torque moves
        the state as the model does."""
        steps, n = step_count(horizon_s, max_step_s), self.model.nv
        step = self.step_jacobian(position, velocity, torque, horizon_s / steps)
        if not self.resists_within_step:
            return matrix_power(step, steps)
        carried = np.eye(3 * n)  # [[A, B], [0, I]]^steps: its top right is Σ Aᵏ·B
        carried[: 2 * n, : 2 * n] = step
        pushes, after = self.mass_matrix(position) * PUSH, np.empty((n + 1, 2 * n))  # column j: PUSH on joint j
        for j, push in enumerate((None, *pushes.T)):  # the step (step_jacobian's) unpushed, then each push
            self._load(position, velocity, torque, push)
            mujoco.mj_step(self.model, self._data)
            after[j, :n], after[j, n:] = self._qpos, self._qvel
        self._qfrc_applied.fill(0.0)
        carried[: 2 * n, 2 * n :] = (after[1:] - after[0]).T / PUSH
        return matrix_power(carried, steps)[: 2 * n]

    def mass_matrix(self, position: np.ndarray) -> np.ndarray:
        """M(q), kg·m²: only the position stages that build it (the whole forward pass gives the same matrix)."""
        d = self._data
        self._qpos[:] = position
        mujoco.mj_kinematics(self.model, d)
        mujoco.mj_comPos(self.model, d)
        mujoco.mj_crb(self.model, d)
        matrix = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, d, matrix)
        return matrix

    def adjusted(self, *, inertia=None, damping=None, coulomb_friction=None) -> ArmDynamics:
        """This model, changed in place, with per-joint values over the URDF's (None: the URDF's): ``damping``
        N·m·s/rad, ``coulomb_friction`` N·m, ``inertia`` kg·m² at q = 0 (M(0)'s diagonal), made up by rotor inertia:
        a coupled model can add inertia about a joint, not take a link's away."""
        dofs = self.model.jnt_dofadr[: len(self.joint_names)]
        if inertia is not None:
            extra = np.asarray(inertia, float) - np.diag(self.mass_matrix(np.zeros(len(dofs))))
            if np.any(extra < -1e-9):
                j = int(np.argmin(extra))
                raise ConfigError(
                    f"model_inertia: {self.joint_names[j]}'s {inertia[j]:g} kg·m² is below its links' own "
                    f"{inertia[j] - extra[j]:.4g} at q = 0; a chain's model can add inertia (a rotor's), not remove it"
                )
            self.model.dof_armature[dofs] += np.maximum(extra, 0.0)
        if damping is not None:
            self.model.dof_damping[dofs] = damping
        if coulomb_friction is not None:
            self.coulomb_friction = np.array(coulomb_friction, dtype=float)
            self._dofs = dofs
            self.model.dof_frictionloss[dofs] = self.coulomb_friction
            # Friction given (identified) is a real arm's: it sticks, as the filter's prediction must have it
            make_friction_stick(self.model, dofs[self.coulomb_friction > 0], self.model.opt.timestep)
        self._choose_inverse()
        self.adjustments = {
            name: value
            for name, value in (("inertia", inertia), ("damping", damping), ("coulomb_friction", coulomb_friction))
            if value is not None
        }
        return self

    def describe(self) -> str:
        """One line: the URDF's coupled model and the per-joint values set over it."""
        units = {"inertia": "kg·m² at q = 0", "damping": "N·m·s/rad", "coulomb_friction": "N·m"}
        said = [
            f"{name} [{', '.join(f'{v:.4g}' for v in value)}] {units[name]}" for name, value in self.adjustments.items()
        ]
        return "arm model: the URDF's, coupled (MuJoCo)" + (", with " + ", ".join(said) if said else "")

    @property
    def damping(self) -> np.ndarray:
        """Viscous joint damping, N·m·s/rad."""
        return self.model.dof_damping.copy()
