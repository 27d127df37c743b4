"""The arm simulated by MuJoCo (:class:`MujocoPlant`): joint torques, holding brakes, and an external
disturbance with its bounds (:func:`check_disturbance`: the bounds are the plant's)."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.model.mujoco_model import effort_limits, joint_names, joint_units, load_model
from robot_controller.core.model.payload import Payload
from robot_controller.core.model.plant_variation import PlantVariation

# Below this speed (rad/s) a braking joint counts as stopped and is held where it is.
BRAKE_LOCK_SPEED = 0.05

# An external disturbance's cap per joint, N·m (a shove, not a crash), and on its duration, s.
MAX_DISTURBANCE_NM = 100.0
MAX_DISTURBANCE_S = 60.0


def check_disturbance(data, joint_count: int) -> tuple[np.ndarray, float] | str:
    """``[torque_nm…, duration_s]`` (one torque per joint) as ``(torque, duration_s)``, or a reason to drop it. A
    torque beyond ``MAX_DISTURBANCE_NM`` is returned as sent: the caller caps it (and says so). 0 s ends the current
    one."""
    data = np.asarray(data, dtype=float).ravel()
    if data.size != joint_count + 1:
        return (
            f"expected {joint_count + 1} values ({joint_count} torque(s) in N·m, then the duration in s), "
            f"got {data.size}"
        )
    if not np.all(np.isfinite(data)):
        return "non-finite torque or duration"
    duration = float(data[-1])
    if duration < 0:
        return f"negative duration {duration:g} s"
    if duration > MAX_DISTURBANCE_S:
        return f"duration {duration:g} s over the {MAX_DISTURBANCE_S:g} s limit"
    return data[:-1].copy(), duration


class MujocoPlant:
    """The arm simulated by MuJoCo. Two torques act on a joint: the actuator's (``step``'s, within the URDF's
    effort limit, none on a braked joint) and an external disturbance (``set_disturbance``: a push, neither limited
    by the drive nor cut by a brake). A brake holds against it as against gravity: a joint at rest stays locked.
    ``payload`` and ``variation``: what the arm has that its URDF does not."""

    def __init__(
        self,
        urdf_path: str | Path,
        physics_dt: float = 0.001,
        payload: Payload | None = None,
        variation: PlantVariation | None = None,
    ) -> None:
        if payload is not None and variation is not None and variation.payload is not None:
            raise ConfigError("payload: given twice, as the plant's payload and in its variation")
        self.model = load_model(
            urdf_path, physics_dt, payload if payload is not None or variation is None else variation.payload
        )
        if variation is not None:
            variation.apply(self.model)
        self.data = mujoco.MjData(self.model)
        self.joint_names = joint_names(self.model)
        self.joint_units = joint_units(self.model)  #: "rad" or "m" per joint
        self.physics_dt = float(self.model.opt.timestep)
        dofs = self.model.jnt_dofadr[: self.joint_count]
        self._free_frictionloss = self.model.dof_frictionloss[dofs].copy()
        self._free_solref = self.model.dof_solref[dofs].copy()
        self._braked = np.zeros(self.joint_count, dtype=bool)
        self._any_braked = False  #: whether any joint's brake is engaged (``_braked.any()``, kept per change)
        self._locked_at = np.full(self.joint_count, np.nan)  #: where each braked joint came to rest, rad
        self.effort_limit = effort_limits(self.model)
        self._effort_low = -self.effort_limit
        self._qfrc_applied = self.data.qfrc_applied  # a view into MjData, kept: one attribute lookup less per step
        self._actuator = np.zeros(self.joint_count)  #: the actuator's torque in the last step, N·m
        self._disturbance = np.zeros(self.joint_count)  #: the external torque being applied, N·m
        self._disturbance_steps = 0  #: physics steps it still lasts
        self._disturbance_last = np.zeros(self.joint_count)  #: the external torque in the last step, N·m
        self._no_disturbance = np.zeros(self.joint_count)  #: never written to: shared, not copied, per step
        mujoco.mj_forward(self.model, self.data)

    @property
    def time_s(self) -> float:
        return float(self.data.time)

    @property
    def joint_count(self) -> int:
        return len(self.joint_names)

    def reset(self, position: np.ndarray, velocity: np.ndarray | None = None) -> None:
        mujoco.mj_resetData(self.model, self.data)
        self.set_disturbance(np.zeros(self.joint_count), 0.0)
        self.data.qpos[:] = position
        self.data.qvel[:] = 0.0 if velocity is None else velocity
        mujoco.mj_forward(self.model, self.data)

    def step(self, torque: np.ndarray, n_steps: int = 1) -> None:
        """Hold ``torque`` (N·m) for ``n_steps`` physics steps; a braked joint gets none, the others no more
        than their URDF ``effort`` limit (``effort_limit``), as a real drive limits its current."""
        torque = np.minimum(np.maximum(torque, self._effort_low), self.effort_limit)  # np.clip: a new array
        self._actuator = np.where(self._braked, 0.0, torque) if self._any_braked else torque
        # The disturbance, if one is on, for as many of these steps as it still lasts.
        disturbed = min(n_steps, self._disturbance_steps)
        if disturbed > 0:
            self._qfrc_applied[:] = self._actuator + self._disturbance
            self._run(disturbed)
            self._disturbance_last = self._disturbance.copy()
            self._disturbance_steps -= disturbed
            if self._disturbance_steps == 0:
                self._disturbance = np.zeros(self.joint_count)
        if n_steps > disturbed:
            self._qfrc_applied[:] = self._actuator
            self._run(n_steps - disturbed)
            self._disturbance_last = self._no_disturbance

    def _run(self, n_steps: int) -> None:
        if not self._any_braked:
            mujoco.mj_step(self.model, self.data, n_steps)  # MuJoCo's own loop: the same steps
            return
        for _ in range(n_steps):
            mujoco.mj_step(self.model, self.data)
            self._hold_braked_joints()

    def set_disturbance(self, torque: np.ndarray, duration_s: float) -> None:
        """Apply an external ``torque`` (N·m per joint, the caller bounds it) for the next ``duration_s`` of physics
        time (whole steps), replacing any current one; 0 s ends it."""
        torque = np.asarray(torque, dtype=float).reshape(self.joint_count)
        steps = int(round(max(0.0, float(duration_s)) / self.physics_dt))
        self._disturbance = torque.copy() if steps > 0 else np.zeros(self.joint_count)
        self._disturbance_steps = steps if np.any(torque != 0.0) else 0

    @property
    def disturbance_active(self) -> bool:
        """Whether a disturbance will act in the next physics step."""
        return self._disturbance_steps > 0

    @property
    def disturbance_remaining_s(self) -> float:
        return self._disturbance_steps * self.physics_dt

    @property
    def disturbance_torque(self) -> np.ndarray:
        """The external torque that acted on each joint in the last physics step, N·m."""
        return self._disturbance_last.copy()

    def _hold_braked_joints(self) -> None:
        """Lock a braked joint where it came to rest (MuJoCo's friction, a soft constraint, would let it creep)."""
        qpos, qvel = self.data.qpos, self.data.qvel
        for j in np.flatnonzero(self._braked):
            dof, adr = self.model.jnt_dofadr[j], self.model.jnt_qposadr[j]
            if np.isnan(self._locked_at[j]) and abs(qvel[dof]) < BRAKE_LOCK_SPEED:
                self._locked_at[j] = qpos[adr]
            if not np.isnan(self._locked_at[j]):
                qpos[adr], qvel[dof] = self._locked_at[j], 0.0

    def set_brakes(self, engaged: np.ndarray, holding_torque_nm: float) -> None:
        """Engage or release each joint's holding brake: dry friction of ``holding_torque_nm`` that holds the arm
        against gravity and stops a moving one at (holding torque − load) / inertia."""
        engaged = np.asarray(engaged, dtype=bool)
        dofs = self.model.jnt_dofadr[: self.joint_count]
        self.model.dof_frictionloss[dofs] = np.where(engaged, holding_torque_nm, self._free_frictionloss)
        # Stiff: the brake acts within a couple of physics steps.
        self.model.dof_solref[dofs] = np.where(engaged[:, None], [2 * self.physics_dt, 1.0], self._free_solref)
        self._locked_at = np.where(engaged & self._braked, self._locked_at, np.nan)
        self._braked = engaged
        self._any_braked = bool(engaged.any())

    @property
    def applied_torque(self) -> np.ndarray:
        """The actuator's torque on each joint in the last step, N·m (without ``disturbance_torque``)."""
        return self._actuator.copy()

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.data.qpos.copy(), self.data.qvel.copy()
