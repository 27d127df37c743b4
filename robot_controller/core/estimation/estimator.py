"""State estimation: a Kalman filter on joint position and velocity, with
the applied torque as input, so the controller acts on a cleaner state than
the raw encoder reading; optionally with a third state per joint, an
unknown external torque (a disturbance observer).

Per joint, the state is ``x = [q, v]``. The prediction integrates the arm
model (MuJoCo forward dynamics, or the analytic arm) over the control period
under the torque commanded last, in steps no longer than the plant's own
(``model_step_s``); its covariance uses the model linearised about the
filtered state (gravity's stiffness, the damping) with white acceleration
noise, which is what the torque input leaves uncertain. Joints are filtered
independently (the reference arm has one).

The model, like the simulated plant (MuJoCo's default integrator), steps
semi-implicitly: each step's velocity is the one the position moves by over
that step. A velocity state, read or filtered, is therefore the arm's
velocity half a step before its position's instant;
:meth:`JointKalmanFilter.velocity_at_instant` gives the one at the instant.

**Disturbance observer** (``estimate_disturbance``): the state becomes
``x = [q, v, d]`` per joint, ``d`` an external torque (N·m) acting beside the
actuator's (a push, a load, and whatever the arm model gets wrong), modelled
as a random walk of ``disturbance_noise_std`` N·m/√s. The model moves the arm
under the actuator's torque (limited to the effort limit, as the drive
limits it) plus ``d`` (not limited: it is not the drive's), its acceleration
``d_j·(M⁻¹)_jj`` on joint j. Mostly the velocity reading tells ``d`` apart: a torque ``d``
held over a period T changes the velocity by ``d·T/I`` more than the model
says.

On a chain of joints, each joint's filter sees only what its own readings
show: an acceleration beyond the model's, ``α_j``, whatever torques on which
joints caused it. So ``d_j`` is that acceleration in torque units on the
joint's own axis (``α_j / (M⁻¹)_jj``), which keeps the joints' filters
independent, and the torque that cancels the accelerations is ``M(q)·α``
(:attr:`JointKalmanFilter.disturbance`): exactly the external torques,
coupling included. (With ``M⁻¹·d`` in the prediction instead, one joint's
estimate moves the others' predictions, which their filters take for a
disturbance of their own; on the two-joint arm that doubled the tracking
error.) On one joint the two are the same. The estimate is kept within ``±disturbance_limit`` (the controller's
torque limit: a larger one could not be compensated anyway) and starts from
0 whenever the filter does (:meth:`JointKalmanFilter.reset`).

**Trust**: while the readings agree with it, the filter trusts its model
(small process noise) and so averages the sensor noise over about a second;
a reading that stands out as a torque step would is taken as a jump of ``d``;
while the readings disagree it moves to following them; a reading no torque
within the limit explains restarts it. What it makes of each reading's
surprise is in :mod:`robot_controller.core.estimation.innovation`.

The filter's parts: its tuning and process noise in ``kalman_config``, the update on
arrays in ``kalman_arrays``, the running one-joint update on floats in
``kalman_one_joint``, the model's slopes and the steady-state gain in ``kalman_linear``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.estimation import innovation
from robot_controller.core.estimation.kalman_arrays import ArrayPath, _solve_symmetric, _StateIndex, inverse_2x2
from robot_controller.core.estimation.kalman_config import (
    DISTURBANCE_PRIOR_STD_NM,
    KalmanConfig,
    process_noise,
)
from robot_controller.core.estimation.kalman_linear import Linearisation, steady_state_gain
from robot_controller.core.estimation.kalman_one_joint import OneJointModel, OneJointPath, _ArrayCalls, _power_2x2

__all__ = [
    "DISTURBANCE_PRIOR_STD_NM",
    "JointKalmanFilter",
    "KalmanConfig",
    "MassMatrix",
    "OneJointModel",
    "Predictor",
    "StepJacobian",
    "_power_2x2",
    "_solve_symmetric",
    "inverse_2x2",
    "process_noise",
    "steady_state_gain",
]

# (q, v, torque, horizon_s, max_step_s=, external_nm=) → predicted (q, v): the arm model's ``predict``
Predictor = Callable[..., tuple[np.ndarray, np.ndarray]]
# (q, v, torque, step_s) → one model step's ∂[q'; v']/∂[q; v], (2n, 2n)
StepJacobian = Callable[[np.ndarray, np.ndarray, np.ndarray, float], np.ndarray]
# q → the arm's mass matrix M(q), (n, n), kg·m²
MassMatrix = Callable[[np.ndarray], np.ndarray]


class JointKalmanFilter(OneJointPath, ArrayPath, Linearisation):
    """Predict with the arm model, correct with each reading.

    The state is ``x`` (n, m): per joint ``q, v`` (and ``d``). Its covariance
    is one matrix over every joint's state (``P[0]``, nm × nm, joint by joint),
    since on a chain of joints each joint's prediction leans on the others'
    states (gravity, inertia and Coriolis couple them): a wrist's predicted
    acceleration moves by tens of rad/s² per radian of the shoulder, so the
    shoulder's uncertainty is the wrist's too. The tests of each reading's
    surprise (agreement, jumps, beyond any torque) look at each joint's own.
    With ``independent_joints`` the joints are separate arms (the batch
    harness's gain sets, one joint each): one m × m covariance per joint
    (``P``, n × m × m), the same arithmetic on each.

    :param predictor: the arm model's ``predict`` (q, v, torque, horizon_s, max_step_s, external_nm)
    :param jacobian: one model step's slopes ``(q, v, torque, step_s) → ∂[q'; v']/∂[q; v]`` (2n × 2n);
        None: by finite differences of ``predictor``
    :param estimate_disturbance: add the external torque ``d`` to the state
        (the disturbance observer); needs ``mass_matrix``
    :param mass_matrix: the arm's M(q) (what ``d`` accelerates)
    :param disturbance_limit: N·m per joint, the bound on ``|d|`` (none if None)
    :param torque_scale: per joint, the factor on the observer's torque σs (its noise and the
        jump's and start's prior): the joint's inertia over the one they were chosen for, so that
        a wrist and a shoulder get the same observer in acceleration (None: 1 on every joint)
    :param independent_joints: the joints do not act on one another (separate one-joint arms)
    :param one_joint: for one joint, the same arm model on floats (``ArmDynamics.one_joint``):
        the running filter's update asks it instead of ``predictor``, ``jacobian`` and
        ``mass_matrix`` (the same numbers, to rounding)
    """

    def __init__(
        self,
        config: KalmanConfig,
        joint_count: int,
        predictor: Predictor,
        *,
        jacobian: StepJacobian | None = None,
        estimate_disturbance: bool = False,
        mass_matrix: MassMatrix | None = None,
        disturbance_limit: np.ndarray | None = None,
        torque_scale: np.ndarray | None = None,
        independent_joints: bool = False,
        one_joint: OneJointModel | None = None,
    ) -> None:
        if estimate_disturbance and mass_matrix is None:
            raise ConfigError("disturbance_observer: needs the arm model's mass matrix")
        self.config = config
        self.predictor = predictor
        self.jacobian = jacobian
        self.joint_count = joint_count
        self.estimates_disturbance = bool(estimate_disturbance)
        self.mass_matrix = mass_matrix
        self.disturbance_limit = (
            np.full(joint_count, np.inf)
            if disturbance_limit is None
            else np.broadcast_to(np.asarray(disturbance_limit, float), (joint_count,)).copy()
        )
        self.size = m = 3 if self.estimates_disturbance else 2
        n = joint_count
        self._mismatch = config.at_mismatch()  #: the filter while its readings disagree with it
        #: σ (disturbance N·m/√s, acceleration rad/s²) while the readings agree, and at the mismatch
        #: per joint, how much heavier than the joint the torque σs were chosen for (None: 1 on every joint)
        self._torque_scale = None if torque_scale is None else np.asarray(torque_scale, dtype=float).reshape(n)
        self._agreeing_std = np.array([config.disturbance_noise_std, config.acceleration_noise_std])
        self._mismatch_std = np.array([self._mismatch.disturbance_noise_std, self._mismatch.acceleration_noise_std])
        self._agreeing_std_floats = (float(config.disturbance_noise_std), float(config.acceleration_noise_std))
        self._mismatch_std_floats = (
            float(self._mismatch.disturbance_noise_std),
            float(self._mismatch.acceleration_noise_std),
        )
        self.x: np.ndarray | None = None  # (n, 2): q, v per joint; (n, 3): q, v, d
        #: groups of joints that act on one another: one (the arm), or each joint its own
        self._groups, self._per_group = (n, 1) if independent_joints else (1, n)
        k = self._per_group
        #: per group, joint by joint: [q1, v1, (d1), q2, v2, ...]
        self.P = np.zeros((self._groups, k * m, k * m))
        self.R = np.diag([config.position_noise_std**2, config.velocity_noise_std**2])
        self._r_diagonal = (float(self.R[0, 0]), float(self.R[1, 1]))
        self._R_all = np.kron(np.eye(k), self.R)
        #: where each reading (q1, v1, q2, v2, ...) of a group sits in its state
        self._read = (np.arange(k)[:, None] * m + np.arange(2)[None, :]).reshape(-1)
        self._index = _StateIndex(k, m)
        self.time_s: float | None = None
        #: per joint, rad/s² per N·m of external torque on each joint ((n, n): M⁻¹ at the last estimate)
        self._inverse_mass: np.ndarray | None = None
        self._own_inverse_mass: np.ndarray | None = None  #: its diagonal, (M⁻¹)_jj: d_j's acceleration per N·m
        self._mass: np.ndarray | None = None  #: M(q) at the last estimate, kg·m²
        #: per joint, how many readings were taken as a jump of the external torque
        self.jump_count = np.zeros(joint_count, dtype=int)
        #: per joint, how many readings no external torque within the limit could explain (restarts)
        self.restart_count = np.zeros(joint_count, dtype=int)
        #: per joint, the innovation's squared Mahalanobis distance, averaged (2 while readings agree)
        self._distance_sq_average = np.full(joint_count, innovation.UNPROVEN_DISTANCE_SQ)
        #: one joint: the arm model on floats (its own, or the callables above through arrays)
        self._one_joint_calls: OneJointModel | _ArrayCalls | None = None
        if joint_count == 1:
            self._one_joint_calls = _ArrayCalls(self) if one_joint is None else one_joint

    def reset(self) -> None:
        """Forget the state: the next reading starts the filter again (and the disturbance from 0)."""
        self.x = None
        self.time_s = None
        self._inverse_mass = None
        self._own_inverse_mass = None
        self._mass = None

    @property
    def joint_covariance(self) -> np.ndarray:
        """Each joint's own covariance (n, m, m): the diagonal blocks of ``P``."""
        n, m = self.joint_count, self.size
        return self.P[(slice(None), *self._index.blocks)].reshape(n, m, m)

    @property
    def disturbance_state(self) -> list[float] | None:
        """The observer's own state per joint (what :attr:`disturbance` is made of), or None."""
        if not self.estimates_disturbance or self.x is None:
            return None
        return self.x[:, 2].tolist()

    def set_disturbance_state(self, state: list[float]) -> None:
        """Put ``state`` (a :attr:`disturbance_state`) in the observer's place, e.g. a held average."""
        if self.estimates_disturbance and self.x is not None:
            self.x[:, 2] = state

    @property
    def disturbance(self) -> np.ndarray:
        """The estimated external torque on each joint, N·m: the one that gives the
        unexplained accelerations, ``M(q)·α`` (0 without the observer or a state)."""
        if not self.estimates_disturbance or self.x is None:
            return np.zeros(self.joint_count)
        if self.joint_count == 1 or self._mass is None:
            return self.x[:, 2].copy()  # one joint: α·I is its d
        return self._mass @ self._disturbance_acceleration()

    def _disturbance_acceleration(self) -> np.ndarray:
        """rad/s² the estimate leaves unexplained on each joint, ``α_j = d_j·(M⁻¹)_jj`` (0 without one)."""
        if not self.estimates_disturbance or self.x is None or self._inverse_mass is None:
            return np.zeros(self.joint_count)
        return self._own_inverse_mass * self.x[:, 2]

    def _disturbance_torque(self) -> np.ndarray | None:
        """The torque that gives ``α`` on the model, N·m (None without one): what the prediction applies."""
        if not self.estimates_disturbance or self.x is None or self._mass is None:
            return None
        if self.joint_count == 1:  # the same product on floats
            return np.array([self._mass.item() * (self._own_inverse_mass.item() * self.x.item(0, 2))])
        return self._mass @ self._disturbance_acceleration()

    def _set_mass(self, position: np.ndarray) -> None:
        """The mass matrix and its inverse at ``position``, for the next prediction and the estimate's torque."""
        calls = self._one_joint_calls
        if calls is not None and calls.mass is not None:  # one joint's constant M
            if self._mass is not None:
                return
            self._mass = np.array([[calls.mass]])
        else:
            self._mass = np.asarray(self.mass_matrix(np.asarray(position, float)), dtype=float)
        # One joint: 1/M is what LAPACK's inverse of a 1 × 1 comes to, without its call.
        self._inverse_mass = 1.0 / self._mass if self.joint_count == 1 else np.linalg.inv(self._mass)
        self._own_inverse_mass = self._inverse_mass.diagonal().copy()

    def update(
        self,
        time_s: float,
        position: np.ndarray,
        velocity: np.ndarray,
        torque: np.ndarray,
        torque_change: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Take a reading stamped ``time_s``; ``torque`` is what acted since the last one.
        ``torque_change`` (N·m per joint): how much the command changed about the
        start of that span, when the instant it took effect is uncertain
        (``command_timing_uncertainty_s``).

        Returns the filtered ``(position, velocity)``.
        """
        if self.joint_count == 1 and self.x is not None and self.time_s is not None and 0 < time_s - self.time_s < 1.0:
            return self._update_one_joint(time_s, position, velocity, torque, torque_change)
        return self._update_joints(time_s, position, velocity, torque, torque_change)

    def _step_model(
        self, q: np.ndarray, v: np.ndarray, torque: np.ndarray, horizon_s: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """The arm model over ``horizon_s`` under ``torque`` (and the estimated
        external torque, if any), in steps of at most ``model_step_s``."""
        return self.predictor(
            q, v, torque, horizon_s, max_step_s=self.config.model_step_s, external_nm=self._disturbance_torque()
        )

    def predict(
        self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray, horizon_s: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """The state ``horizon_s`` seconds ahead under the actuator's ``torque``
        (N·m) and the external torque as estimated now (a latency compensation
        or a coast on the model that agrees with the filter)."""
        if horizon_s <= 0:
            return np.array(position, dtype=float), np.array(velocity, dtype=float)
        return self._step_model(np.array(position, dtype=float), np.array(velocity, dtype=float), torque, horizon_s)

    def velocity_at_instant(self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray) -> np.ndarray:
        """The velocity (rad/s) at the instant of the state ``(position, velocity)``
        under ``torque`` (N·m), and the estimated external torque if any: the
        mean of the velocity over the model step that ended there (the
        state's own) and over the one that starts there. It
        is what a reference's velocity at that instant compares with: with the
        state's own, an arm exactly on the reference shows a velocity error of
        acceleration × model_step_s / 2, which the law's D term turns into a
        systematic torque (0.3 mrad of tracking error on the reference sine)."""
        h = self.config.model_step_s
        calls = self._one_joint_calls
        if calls is not None and calls.mass is not None:  # one joint, on floats
            v, external = float(velocity[0]), self._one_joint_disturbance_torque()
            _, ahead = calls.predict(float(position[0]), v, float(torque[0]), h, h, external)
            return np.array([0.5 * (v + ahead)])
        _, ahead = self.predictor(position, velocity, torque, h, max_step_s=h, external_nm=self._disturbance_torque())
        return 0.5 * (velocity + ahead)
