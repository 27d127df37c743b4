"""The physical arm: a ``Plant`` protocol and its MuJoCo implementation.

MuJoCo loads the URDF as it is (``MjSpec.from_file``), so there is no second,
hand-written model to drift from the robot description. Anything else that
moves joints (an analytic model, Gazebo behind a bridge, a hardware driver)
can stand in by providing the same few members.

Longer than our ~250-line guideline: the Plant protocol, the MuJoCo plant with
brakes and disturbances, and the arm's dynamics.
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

import mujoco
import numpy as np

from robot_controller.core.arm_model import step_count
from robot_controller.core.arrays import clip
from robot_controller.core.errors import ConfigError, TimingError
from robot_controller.core.payload import Payload, carrying_link
from robot_controller.core.payload import add_to as add_payload


class Plant(Protocol):
    joint_names: list[str]
    physics_dt: float

    @property
    def time_s(self) -> float: ...

    def reset(self, position: np.ndarray, velocity: np.ndarray | None = None) -> None: ...

    def step(self, torque: np.ndarray, n_steps: int = 1) -> None: ...

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """True ``(position rad, velocity rad/s)`` per joint."""
        ...


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


# Below this speed (rad/s) a braking joint counts as stopped and is held where it is.
BRAKE_LOCK_SPEED = 0.05

# An external disturbance is capped at this torque per joint, N·m (ten times the
# reference arm's effort limit: a shove, not a crash), and at this duration, s.
MAX_DISTURBANCE_NM = 100.0
MAX_DISTURBANCE_S = 60.0


def check_disturbance(data, joint_count: int) -> tuple[np.ndarray, float] | str:
    """Validate a ``/sim/disturbance`` array ``[torque_nm…, duration_s]`` (one
    torque per joint, then the duration) into ``(torque, duration_s)``, or a
    reason to drop it. A torque beyond ``MAX_DISTURBANCE_NM`` is returned as
    sent: the caller caps it (and says so). A duration of 0 ends the current one.

    (Beside the plant rather than in ``core.validation``: the bounds are the plant's.)
    """
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
    """The arm simulated by MuJoCo; torque is applied as generalised force on each joint.

    Two torques act on a joint: the actuator's (``step``'s argument, limited to
    the URDF's effort limit, none on a braked joint) and an external
    disturbance (``set_disturbance``: a push on the arm, not an actuator, so
    neither limited by the drive nor cut by a brake). A brake holds against it
    as against gravity: a joint at rest stays locked; a moving one is slowed
    by up to the holding torque. The two are summed into MuJoCo's ``qfrc_applied``.

    :param urdf_path: robot description
    :param physics_dt: physics step, s (1 ms in the reference scenario)
    :param payload: a load on the last joint's link the URDF does not have
    """

    def __init__(self, urdf_path: str | Path, physics_dt: float = 0.001, payload: Payload | None = None) -> None:
        self.model = load_model(urdf_path, physics_dt, payload)
        self.data = mujoco.MjData(self.model)
        self.joint_names = joint_names(self.model)
        self.physics_dt = float(self.model.opt.timestep)
        dofs = self.model.jnt_dofadr[: self.joint_count]
        self._free_frictionloss = self.model.dof_frictionloss[dofs].copy()
        self._free_solref = self.model.dof_solref[dofs].copy()
        self._braked = np.zeros(self.joint_count, dtype=bool)
        self._any_braked = False  #: whether any joint's brake is engaged (``_braked.any()``, kept per change)
        self._locked_at = np.full(self.joint_count, np.nan)  #: where each braked joint came to rest, rad
        self.effort_limit = effort_limits(self.model)
        self._effort_low = -self.effort_limit
        #: (low, high) N·m of the one joint's effort limit, as floats; None for more joints
        self._one_joint_limit = (
            (self._effort_low.item(), self.effort_limit.item()) if self.effort_limit.shape == (1,) else None
        )
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
        """Hold ``torque`` (N·m) for ``n_steps`` physics steps; a braked joint gets none.

        Whatever it is sent, a joint gets no more than its URDF ``effort`` limit
        (``effort_limit``), as a real drive limits its current.
        """
        if (
            self._one_joint_limit is not None
            and not self._any_braked
            and self._disturbance_steps == 0 < n_steps
            and type(torque) is np.ndarray
            and torque.shape == (1,)
        ):  # one joint, free, undisturbed: the same on floats
            low, high = self._one_joint_limit
            applied = min(max(float(torque.item()), low), high)
            self._actuator = np.array([applied])
            self._qfrc_applied[0] = applied
            mujoco.mj_step(self.model, self.data, n_steps)
            self._disturbance_last = self._no_disturbance
            return
        torque = clip(torque, self._effort_low, self.effort_limit)  # a new array: the caller's is not kept
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
        """Apply an external ``torque`` (N·m per joint) for the next ``duration_s``
        of physics time (whole physics steps), replacing any current one; 0 s
        ends it. Not limited by the effort limit (the caller bounds it), and
        applied to a braked joint too: the brake holds against it."""
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
        """A braked joint that has come to rest is locked where it stopped: MuJoCo's
        friction is a soft constraint and would let a loaded joint creep."""
        qpos, qvel = self.data.qpos, self.data.qvel
        for j in np.flatnonzero(self._braked):
            dof, adr = self.model.jnt_dofadr[j], self.model.jnt_qposadr[j]
            if np.isnan(self._locked_at[j]) and abs(qvel[dof]) < BRAKE_LOCK_SPEED:
                self._locked_at[j] = qpos[adr]
            if not np.isnan(self._locked_at[j]):
                qpos[adr], qvel[dof] = self._locked_at[j], 0.0

    def set_brakes(self, engaged: np.ndarray, holding_torque_nm: float) -> None:
        """Engage or release each joint's holding brake.

        A brake is dry friction of ``holding_torque_nm`` on the joint (MuJoCo's
        friction loss, a constraint): it holds the arm against gravity and stops
        a moving one at (holding torque − load) / inertia, about 570 rad/s² on
        the reference arm, so from 3 rad/s within about 5 ms.
        """
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
        """The actuator's torque on each joint in the last step, N·m (the
        disturbance apart: ``disturbance_torque``)."""
        return self._actuator.copy()

    @property
    def brakes_engaged(self) -> np.ndarray:
        return self._braked.copy()

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.data.qpos.copy(), self.data.qvel.copy()


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
            and _is_one_value(torque)
            and (external_nm is None or _is_one_value(external_nm))
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


def _is_one_value(value: object) -> bool:
    return type(value) is np.ndarray and value.shape == (1,)
