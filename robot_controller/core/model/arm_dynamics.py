"""The arm's multibody dynamics for the controller (:class:`ArmDynamics`), from the
same URDF as the plant on a private ``MjData``, and its one-joint form on Python
floats (:class:`OneJointDynamics`), which the per-tick path of a one-joint arm asks."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from robot_controller.core.arrays import clip, is_one_value
from robot_controller.core.model.arm_model import step_count
from robot_controller.core.model.mujoco_model import effort_limits, joint_names, load_model
from robot_controller.core.model.payload import Payload


class ArmDynamics:
    """The arm's multibody dynamics from the same URDF, on a private ``MjData``:
    what the controller's model-based parts ask of it, coupling between the
    joints included.

    ``torque(q, v, a)`` is the joint torque that produces acceleration ``a``
    at state ``(q, v)``: M(q)·a + Coriolis + damping·v + gravity, from
    MuJoCo's ``mj_inverse``. ``predict`` steps the arm as the plant does
    (``mj_step``: the same integrator, so the same numbers), and
    ``step_jacobian`` linearises one such step (``mjd_transitionFD``).
    """

    def __init__(self, urdf_path: str | Path, payload: Payload | None = None) -> None:
        self.model = load_model(urdf_path, payload=payload)
        self.payload = payload
        self._data = mujoco.MjData(self.model)
        self.joint_names = joint_names(self.model)
        self.effort_limit = effort_limits(self.model)
        self._effort_low = -self.effort_limit
        #: (low, high) N·m of the one joint's effort limit, as floats; None for more joints
        self._one_joint_limit = (
            (self._effort_low.item(), self.effort_limit.item()) if self.effort_limit.shape == (1,) else None
        )
        # Views into the private MjData and the model's options, kept: the controller asks several
        # times a tick, and each lookup through the bindings costs as much as a small array operation.
        d = self._data
        self._qpos, self._qvel, self._qacc = d.qpos, d.qvel, d.qacc
        self._qfrc_applied, self._qfrc_inverse = d.qfrc_applied, d.qfrc_inverse
        self._option = self.model.opt
        #: a one-joint arm's calls on Python floats (None for more joints)
        self.one_joint = OneJointDynamics(self) if self.model.nv == 1 else None

    def torque(self, position: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
        self._qpos[:] = position
        self._qvel[:] = velocity
        self._qacc[:] = acceleration
        mujoco.mj_inverse(self.model, self._data)
        return self._qfrc_inverse.copy()

    def gravity(self, position: np.ndarray) -> np.ndarray:
        zero = np.zeros(self.model.nv)
        return self.torque(position, zero, zero)

    def acceleration(self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray) -> np.ndarray:
        """Forward dynamics: joint acceleration (rad/s²) under ``torque`` at state ``(q, v)``
        (limited to the URDF's effort limit, as :class:`MujocoPlant` applies it)."""
        d = self._data
        d.qpos[:] = position
        d.qvel[:] = velocity
        d.qfrc_applied[:] = np.clip(torque, -self.effort_limit, self.effort_limit)
        mujoco.mj_forward(self.model, d)
        d.qfrc_applied[:] = 0.0
        return d.qacc.copy()

    def _load(
        self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray, external_nm: np.ndarray | None
    ) -> None:
        """The private state at ``(q, v)`` with ``torque`` (within the effort limit) and ``external_nm`` applied."""
        self._qpos[:] = position
        self._qvel[:] = velocity
        if (
            self._one_joint_limit is not None
            and is_one_value(torque)
            and (external_nm is None or is_one_value(external_nm))
        ):
            # One joint: the same clip and sum on floats (each NumPy call costs more than its arithmetic).
            low, high = self._one_joint_limit
            applied = min(max(torque.item(), low), high)
            self._qfrc_applied[0] = applied if external_nm is None else applied + external_nm.item()
            return
        applied = clip(torque, self._effort_low, self.effort_limit)
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
        """State ``horizon_s`` seconds ahead under constant ``torque`` (limited to
        the effort limit) and an ``external_nm`` torque (not limited), in equal
        steps of at most ``max_step_s``: MuJoCo's own steps, as
        :class:`MujocoPlant` takes them (semi-implicit Euler, implicit in the
        joint damping; with the damping explicit instead, the acceleration
        comes out h·D/M too large, a bias a filter that trusts its model turns
        into 0.3 mrad of tracking error)."""
        steps = step_count(horizon_s, max_step_s)
        self._option.timestep = horizon_s / steps
        self._load(position, velocity, torque, external_nm)
        mujoco.mj_step(self.model, self._data, steps)
        self._qfrc_applied.fill(0.0)
        return self._qpos.copy(), self._qvel.copy()

    def step_jacobian(
        self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray, step_s: float
    ) -> np.ndarray:
        """How one step of ``step_s`` moves the state ``[q; v]`` (2n × 2n): the
        step's slopes in every joint's position and velocity (gravity's
        stiffness, damping, Coriolis and the coupling between joints), by
        MuJoCo's finite differences in C."""
        n = self.model.nv
        self._option.timestep = step_s
        self._load(position, velocity, torque, None)
        jacobian = np.zeros((2 * n, 2 * n))
        mujoco.mjd_transitionFD(self.model, self._data, 1e-6, 0, jacobian, None, None, None)
        self._qfrc_applied.fill(0.0)
        return jacobian

    def mass_matrix(self, position: np.ndarray) -> np.ndarray:
        """M(q) at ``position`` (kg·m²): MuJoCo's position stages that build it
        (kinematics, the bodies' inertias, composite rigid bodies), not the whole
        forward pass, which gives the same matrix."""
        d = self._data
        self._qpos[:] = position
        mujoco.mj_kinematics(self.model, d)
        mujoco.mj_comPos(self.model, d)
        mujoco.mj_crb(self.model, d)
        matrix = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, d, matrix)
        return matrix

    @property
    def damping(self) -> np.ndarray:
        """Viscous joint damping, N·m·s/rad."""
        return self.model.dof_damping.copy()


class OneJointDynamics:
    """:class:`ArmDynamics` of a one-joint arm on Python floats: the same MuJoCo calls
    on the same private ``MjData``, so the same numbers, without the arrays in and out
    (on one joint, NumPy's per-call cost is most of the work of a call).

    The mass matrix is made once: with one joint the whole arm turns rigidly about its
    axis, so M(q) is a constant (MuJoCo's varies with q by rounding only, ~1e-15). It
    assumes the model's bodies are not changed after loading (nothing here does).
    """

    def __init__(self, dynamics: ArmDynamics) -> None:
        self.model = dynamics.model
        self._data = dynamics._data
        self._qpos, self._qvel, self._qacc = dynamics._qpos, dynamics._qvel, dynamics._qacc
        self._qfrc_applied, self._qfrc_inverse = dynamics._qfrc_applied, dynamics._qfrc_inverse
        self._option = dynamics._option
        self._low, self._high = dynamics._effort_low.item(), dynamics.effort_limit.item()
        self._slopes = np.zeros((2, 2))
        self.mass = float(dynamics.mass_matrix(np.zeros(1))[0, 0])  #: kg·m², M(q) for every q

    def _load(self, position: float, velocity: float, torque: float, external_nm: float | None) -> None:
        """:meth:`ArmDynamics._load` on floats."""
        self._qpos[0] = position
        self._qvel[0] = velocity
        applied = min(max(torque, self._low), self._high)
        self._qfrc_applied[0] = applied if external_nm is None else applied + external_nm

    def predict(
        self,
        position: float,
        velocity: float,
        torque: float,
        horizon_s: float,
        max_step_s: float,
        external_nm: float | None = None,
    ) -> tuple[float, float]:
        """:meth:`ArmDynamics.predict`: ``(position, velocity)`` ``horizon_s`` ahead."""
        steps = step_count(horizon_s, max_step_s)
        self._option.timestep = horizon_s / steps
        qpos, qvel, qfrc_applied = self._qpos, self._qvel, self._qfrc_applied
        qpos[0] = position  # (:meth:`_load`, written out: called three times a tick)
        qvel[0] = velocity
        applied = min(max(torque, self._low), self._high)
        qfrc_applied[0] = applied if external_nm is None else applied + external_nm
        mujoco.mj_step(self.model, self._data, steps)
        qfrc_applied[0] = 0.0
        return qpos.item(0), qvel.item(0)

    def step_slopes(self, position: float, velocity: float, torque: float, step_s: float) -> list[float]:
        """:meth:`ArmDynamics.step_jacobian`, row by row: ``[∂q'/∂q, ∂q'/∂v, ∂v'/∂q, ∂v'/∂v]``."""
        self._option.timestep = step_s
        self._load(position, velocity, torque, None)
        mujoco.mjd_transitionFD(self.model, self._data, 1e-6, 0, self._slopes, None, None, None)
        self._qfrc_applied[0] = 0.0
        return self._slopes.ravel().tolist()

    def torque(self, position: float, velocity: float, acceleration: float) -> float:
        """:meth:`ArmDynamics.torque`: inverse dynamics, N·m."""
        self._qpos[0] = position
        self._qvel[0] = velocity
        self._qacc[0] = acceleration
        mujoco.mj_inverse(self.model, self._data)
        return self._qfrc_inverse.item(0)
