"""The Kalman filter on each joint's position and velocity, the applied torque its input, optionally with the
disturbance observer (:class:`JointKalmanFilter`); its process noise in :mod:`.process_noise`.
Per joint the state is ``x = [q, v]``. The prediction steps the arm model over the period under
the torque commanded last, in steps of at most ``model_step_s`` (semi-implicitly, as the plant:
a velocity state is the arm's velocity half a model step before its position's instant); its
covariance uses the model linearised about the filtered state, with white acceleration noise.
The observer adds ``d``, an external torque (N·m) as a random walk of ``disturbance_noise_std``
N·m/√s: each joint's ``d_j`` is the acceleration its readings show beyond the model's, ``α_j``, in
torque units on its own axis (``α_j / (M⁻¹)_jj``), so no joint's estimate moves another's
prediction; ``M(q)·α`` (:attr:`~JointKalmanFilter.disturbance`) is the external torque. ``d`` stays
within ``±disturbance_limit`` and starts from 0. What a surprising reading does (jumps, restarts,
mismatch) is in :mod:`.innovation`; a camera's readings of the positions alone in :mod:`.position_readings`."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy._core.multiarray import c_einsum  # np.einsum's own C function, without its Python wrapper
from numpy.linalg import _umath_linalg  # np.linalg's own LAPACK gufuncs, without their wrappers' checks

import robot_controller.core.estimation.innovation as innovation
from robot_controller.core.errors import ConfigError
from robot_controller.core.estimation.config import DISTURBANCE_PRIOR_STD_NM, KalmanConfig, StateIndex
from robot_controller.core.estimation.innovation import MISMATCH_FROM, clearly_within, inverse_2x2
from robot_controller.core.estimation.position_readings import (
    UNREAD_DISTURBANCE_START_STD,
    UNREAD_VELOCITY_START_STD,
    position_covariance,
    positions_update,
    reading_noise,
)
from robot_controller.core.estimation.process_noise import observer_noise, timing_noise_template

# (q, v, torque, horizon_s, max_step_s=, external_nm=) → predicted (q, v): an arm model's ``predict``
Predictor = Callable[..., tuple[np.ndarray, np.ndarray]]
# (q, v, torque, horizon_s, max_step_s) → ∂[q(T); v(T)]/∂[q; v]: an arm model's ``transition``
Transition = Callable[[np.ndarray, np.ndarray, np.ndarray, float, float], np.ndarray]

# q → the arm's mass matrix M(q), (n, n), kg·m²
MassMatrix = Callable[[np.ndarray], np.ndarray]


class JointKalmanFilter:
    """Predict with the arm model, correct with each reading. The state is ``x`` (n, m): per joint ``q, v`` (and
    ``d``); its covariance one matrix over every joint's state (``P[0]``), as each joint's prediction leans on the
    others'; with ``independent_joints``, one m × m per joint.

    :param predictor: the arm model's ``predict``
    :param transition: the arm model's ``transition``: 2n × 2n (or 2n × 3n, how a push moves the state too), or
        n × 2 × 2 for independent joints
    :param estimate_disturbance: add the external torque ``d`` to the state (the observer, which needs
        ``mass_matrix``)
    :param disturbance_limit: N·m per joint, the bound on ``|d|``
    :param torque_scale: per joint, the factor on the observer's torque σs (the joint's inertia over the one
        they were chosen for)
    :param payload_torque_std: per joint, N·m/√s added to the mismatch σ of ``d``: how fast the torque of a
        payload the model lacks changes as the arm turns it
    """

    def __init__(
        self,
        config: KalmanConfig,
        joint_count: int,
        predictor: Predictor,
        *,
        transition: Transition,
        estimate_disturbance: bool = False,
        mass_matrix: MassMatrix | None = None,
        disturbance_limit: np.ndarray | None = None,
        torque_scale: np.ndarray | None = None,
        payload_torque_std: np.ndarray | None = None,
        independent_joints: bool = False,
    ) -> None:
        if estimate_disturbance and mass_matrix is None:
            raise ConfigError("disturbance_observer: needs the arm model's mass matrix")
        self.config = config
        self.predictor = predictor
        self.transition = transition
        self.joint_count = n = joint_count
        self.estimates_disturbance = bool(estimate_disturbance)
        self.mass_matrix = mass_matrix
        limit = np.inf if disturbance_limit is None else np.asarray(disturbance_limit, float)
        self.disturbance_limit = np.broadcast_to(limit, (n,)).copy()
        self.size = m = 3 if self.estimates_disturbance else 2
        mismatch = config.at_mismatch()
        #: per joint, how much heavier than the joint the torque σs were chosen for
        self._torque_scale = np.ones(n) if torque_scale is None else np.asarray(torque_scale, dtype=float).reshape(n)
        #: σ (disturbance N·m/√s, acceleration rad/s²) while the readings agree, and at the mismatch
        self._agreeing_std = np.array([config.disturbance_noise_std, config.acceleration_noise_std])
        self._mismatch_std = np.array([mismatch.disturbance_noise_std, mismatch.acceleration_noise_std])
        if payload_torque_std is not None:  # per joint (n, 2), in the units the torque scale multiplies
            own = np.hypot(mismatch.disturbance_noise_std, np.asarray(payload_torque_std) / self._torque_scale)
            self._mismatch_std = np.column_stack([own, np.full(n, mismatch.acceleration_noise_std)])
        self.x: np.ndarray | None = None  # (n, 2): q, v per joint; (n, 3): q, v, d
        #: groups of joints that act on one another: one (the arm), or each joint its own
        self._groups, self._per_group = g, k = (n, 1) if independent_joints else (1, n)
        self.P = np.zeros((g, k * m, k * m))  #: per group, joint by joint: [q1, v1, (d1), q2, v2, ...]
        self.R = np.diag([config.position_noise_std**2, config.velocity_noise_std**2])
        self._R_all = np.kron(np.eye(k), self.R)
        self._R_joint: np.ndarray | None = None  #: (n, 2, 2) the latest reading's own R, when it said its σs
        self._index = at = StateIndex(k, m)
        self._F = np.zeros((g, k * m, k * m))  #: the transition, rewritten in place each period
        if self.estimates_disturbance:
            self._F[:, at.d, at.d] = 1.0
        self.time_s: float | None = None
        self._mass: np.ndarray | None = None  #: M(q) at the last estimate, kg·m²
        self._own_inverse_mass: np.ndarray | None = None  #: (M⁻¹)_jj there: d_j's acceleration per N·m
        self.jump_count = np.zeros(n, dtype=int)  #: per joint, readings taken as a jump of the external torque
        self.restart_count = np.zeros(n, dtype=int)  #: per joint, readings no torque within the limit explains
        #: per joint, the innovation's squared Mahalanobis distance, averaged (2 while readings agree)
        self._distance_sq_average = np.full(n, innovation.UNPROVEN_DISTANCE_SQ)
        #: the variances (disturbance (N·m)²/s, acceleration (rad/s²)²) while every joint agrees: its σs squared
        self._agreeing_variances = (
            np.square(config.disturbance_noise_std * self._torque_scale),
            np.square(np.full(n, config.acceleration_noise_std)),
        )
        self._reading = np.empty((n, 2))  #: the latest reading, per joint (q, v)
        self._external: np.ndarray | None = None  #: :meth:`_disturbance_torque` of the state as it is

    def reset(self) -> None:
        """Forget the state: the next reading starts the filter again (and the disturbance from 0)."""
        self.x = self.time_s = self._mass = self._own_inverse_mass = self._external = None

    @property
    def joint_covariance(self) -> np.ndarray:
        """Each joint's own covariance (n, m, m): the diagonal blocks of ``P``."""
        n, m = self.joint_count, self.size
        return self.P[(slice(None), *self._index.blocks)].reshape(n, m, m)

    @property
    def disagreeing(self) -> np.ndarray:
        """Per joint, whether its readings disagree with the filter (its noise moving to the mismatch σs)."""
        return self._distance_sq_average > innovation.MISMATCH_FROM

    @property
    def disturbance_state(self) -> list[float] | None:
        """The observer's own state per joint (what :attr:`disturbance` is made of), or None."""
        return self.x[:, 2].tolist() if self.estimates_disturbance and self.x is not None else None

    def set_disturbance_state(self, state: list[float]) -> None:
        """Put ``state`` (a :attr:`disturbance_state`) in the observer's place, e.g. a held average."""
        if self.estimates_disturbance and self.x is not None:
            self.x[:, 2] = state
            self._external = None

    @property
    def disturbance(self) -> np.ndarray:
        """The estimated external torque on each joint, ``M(q)·α``, N·m (0 without the observer or a state)."""
        torque = self._disturbance_torque()
        return np.zeros(self.joint_count) if torque is None else torque.copy()

    def _disturbance_torque(self) -> np.ndarray | None:
        """``M(q)·α``, ``α_j = d_j·(M⁻¹)_jj``, N·m (None without the observer or a state); worked out once per
        state and mass matrix (not to be written to)."""
        if not self.estimates_disturbance or self.x is None or self._mass is None:
            return None
        if self._external is None:
            self._external = self._mass @ (self._own_inverse_mass * self.x[:, 2])
        return self._external

    def _set_mass(self, position: np.ndarray) -> None:
        """The mass matrix and its inverse's diagonal at ``position``."""
        self._external = None
        self._mass = M = self.mass_matrix(position)
        # (M is symmetric positive definite: np.linalg.inv's checks for a singular one never fire)
        self._own_inverse_mass = (1.0 / M if M.shape == (1, 1) else _umath_linalg.inv(M, signature="d->d")).diagonal()

    def update(
        self,
        time_s: float,
        position: np.ndarray,
        velocity: np.ndarray,
        torque: np.ndarray,
        torque_change: np.ndarray | None = None,
        noise: tuple[np.ndarray, np.ndarray | None] | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """Take a reading stamped ``time_s``, ``torque`` (N·m) having acted since the last; returns the filtered
        ``(position, velocity)``. ``torque_change``: how much the command changed about the start of that span,
        when the instant it took effect is uncertain (``command_timing_uncertainty_s``). ``noise``: the reading's own
        σ per joint (a camera's; ``inf``: it says nothing of that joint) and their correlation (or None), its velocity
        unmeasured."""
        n, m = self.joint_count, self.size
        g, k = self._groups, self._per_group
        observer = self.estimates_disturbance
        z = self._reading  # the reading, per joint
        z[:, 0], z[:, 1] = position, velocity
        self._R_joint = None if noise is None else reading_noise(noise[0])
        correlated = noise is not None and noise[1] is not None and k > 1
        if self.x is None or self.time_s is None or not (0 < time_s - self.time_s < 1.0):
            self.x = np.zeros((n, m))
            self.P = np.zeros((g, k * m, k * m))
            if observer:
                self._set_mass(position)
            self._start(np.ones(n, dtype=bool), z)
            self.time_s = time_s
            return position.copy(), velocity.copy()
        dt = time_s - self.time_s
        self.time_s = time_s
        x_pred, P_pred, b = self._predict(torque, dt, torque_change)
        config = self.config
        if self._R_joint is not None:  # no velocity read: none to be surprised by, nor to restart a joint from
            z[:, 1] = x_pred[:, 1]
        at = self._index
        if at.block_shape == (m, m):  # each joint its own group: its process noise is the whole block
            own = P_pred[(slice(None), *at.own_readings)]
        else:  # one group (matmul's product is contiguous: the flat array is a view)
            own = P_pred.take(at.flat_own_readings)
        surprise = z - x_pred[:, :2]  # the innovation, per joint
        S_joint = own.reshape(n, 2, 2) + (self.R if self._R_joint is None else self._R_joint)
        S_inv = inverse_2x2(S_joint)
        distance_sq = c_einsum("ni,nij,nj->n", surprise, S_inv, surprise)  # (innovation.quadratic)
        jumped = None
        # Neither a jump nor a reading beyond any external torque while every surprise is small.
        sigma = config.jump_detection_sigma
        may_jump = observer and sigma > 0 and not clearly_within(distance_sq, sigma)
        may_be_beyond = observer and not clearly_within(distance_sq, innovation.BEYOND_SIGMA)
        if may_jump or may_be_beyond:
            step = np.empty((n, 2))  # the reading's change per N·m of a step
            step[:, 0], step[:, 1] = 0.5 * b * dt * dt, b * dt
        if may_jump:
            jumped = (self._distance_sq_average < innovation.MISMATCH_FROM) & innovation.looks_like_a_jump(
                surprise, S_inv, distance_sq, step, sigma
            )
            if not any(jumped.tolist()):
                jumped = None
            else:
                jump_std = DISTURBANCE_PRIOR_STD_NM * self._torque_scale
                innovation.allow_jumps(P_pred, jumped, jump_std, b, dt, self._per_group)
                self.jump_count += jumped
        self._distance_sq_average = innovation.updated_average(self._distance_sq_average, distance_sq, jumped, dt)
        P_read = P_pred[:, at.read, :] if k == 1 else P_pred.take(at.read, axis=1)  # (g, 2k, km)
        if k == 1 and jumped is None:  # S is each joint's own block, inverted above
            K = np.matmul(S_inv, P_read).transpose(0, 2, 1)  # (g, m, 2)
        else:
            S = P_pred[(slice(None), *at.readings)] if k == 1 else P_pred.take(at.flat_readings).reshape(1, 2 * k, -1)
            if self._R_joint is None:
                S += self._R_all
            else:  # each joint's own R on the diagonal, and how the positions' errors go together
                S.reshape(S.shape[0], -1)[:, :: 2 * k + 1] += self._R_joint.diagonal(axis1=1, axis2=2).reshape(-1)
                if correlated:
                    between = position_covariance(*noise)
                    np.fill_diagonal(between, 0.0)  # (the diagonal is in already)
                    S[0, 0::2, 0::2] += between
            # (S is a covariance, positive definite: np.linalg.solve's checks for a singular one never fire)
            K = inverse_2x2(S) @ P_read if k == 1 else _umath_linalg.solve(S, P_read, signature="dd->d")
            K = K.transpose(0, 2, 1)
        gain = np.matmul(K, surprise.reshape(g, 2 * k, 1))[:, :, 0]
        self.x = x = (x_pred.reshape(g, k * m) + gain).reshape(n, m)
        P = P_pred - np.matmul(K, P_read)
        self.P = 0.5 * (P + P.transpose(0, 2, 1))
        self._external = None
        if observer:
            limit = self.disturbance_limit
            x[:, 2] = np.minimum(np.maximum(x[:, 2], -limit), limit)
            if may_be_beyond:
                unexplainable = innovation.beyond_any_disturbance(surprise, S_joint, step[:, 1], limit)
                if any(unexplainable.tolist()):
                    self._start(unexplainable, z)
                    self.restart_count += unexplainable
        if not all(map(math.isfinite, self.x.ravel().tolist())):  # a model pushed past what it integrates: restart
            self.x, self.P = np.zeros((n, m)), np.zeros((g, k * m, k * m))
            self._start(np.ones(n, dtype=bool), z)
            self.restart_count += 1
        return self.x[:, 0].copy(), self.x[:, 1].copy()

    def _predict(
        self, torque: np.ndarray, dt: float, torque_change: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """The state and covariance ``dt`` s on under ``torque``, and each joint's acceleration per N·m (or None)."""
        q, v = self.x[:, 0], self.x[:, 1]
        F = self._transition(q, v, torque, dt)
        config = self.config
        timing_uncertain = (
            torque_change is not None and config.command_timing_uncertainty_s > 0 and self.mass_matrix is not None
        )
        external = self._disturbance_torque()  # of the last estimate
        q_pred, v_pred = self.predictor(q, v, torque, dt, max_step_s=config.model_step_s, external_nm=external)
        b = None
        if self.estimates_disturbance or timing_uncertain:
            self._set_mass(q)
            b = self._own_inverse_mass  # rad/s² per N·m on each joint's own axis
        variance_d, variance_a = self._noise_variances()
        if self.estimates_disturbance:
            Q = observer_noise(dt, b, variance_d, variance_a)
        else:
            G = np.array([0.5 * dt * dt, dt])
            Q = np.outer(G, G) * variance_a[:, None, None]
        if timing_uncertain:  # a velocity step of unknown size (the change acting sooner or later)
            sigma_v = np.abs(torque_change) * config.command_timing_uncertainty_s * b
            Q[:, :2, :2] += timing_noise_template(dt) * (sigma_v**2)[:, None, None]
        x_pred = self.x.copy()
        x_pred[:, 0], x_pred[:, 1] = q_pred, v_pred
        P_pred = np.matmul(np.matmul(F, self.P), F.transpose(0, 2, 1))
        at, m = self._index, self.size
        if at.block_shape == (m, m):  # each joint its own group: its process noise is the whole block
            P_pred += Q
        else:  # one group (matmul's product is contiguous: the flat array is a view)
            P_pred.reshape(-1)[at.flat_blocks] += Q.reshape(-1)  # each joint's own process noise
        return x_pred, P_pred, b

    def advance(self, time_s: float, torque: np.ndarray) -> None:
        """The prediction alone, to ``time_s`` under ``torque`` (N·m): between readings slower than the commands (a
        camera's) each command acts over its own span."""
        if self.x is None or self.time_s is None or not (0 < time_s - self.time_s < 1.0):
            return
        dt, self.time_s = time_s - self.time_s, time_s
        self.x, P, _ = self._predict(torque, dt)
        self.P = 0.5 * (P + P.transpose(0, 2, 1))
        self._external = None

    def correct_position(
        self, position: np.ndarray, position_std: np.ndarray, correlation: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """A second reading of the positions alone at the filter's time (a late camera's, brought to it by the filter's
        motion since its stamp), with their σs (``inf``: none) and correlation; returns the filtered (q, q̇)."""
        if self.x is None:
            raise ValueError("correct_position: the filter has no state yet")
        g, k, m = self._groups, self._per_group, self.size
        covariance = position_covariance(position_std, correlation if k > 1 else None)
        x, self.P = positions_update(self.x.reshape(g, k * m), self.P, self._index.q, position, covariance)
        self.x = x.reshape(self.joint_count, m)
        self._external = None
        if self.estimates_disturbance:
            self.x[:, 2] = np.clip(self.x[:, 2], -self.disturbance_limit, self.disturbance_limit)
        return self.x[:, 0].copy(), self.x[:, 1].copy()

    def _transition(self, q: np.ndarray, v: np.ndarray, torque: np.ndarray, dt: float) -> np.ndarray:
        """The model linearised at ``(q, v)`` over ``dt`` (per group, km × km); ``d`` moves its own joint as a
        torque there would."""
        F, at = self._F, self._index
        slopes = self.transition(q, v, torque, dt, self.config.model_step_s)
        read, flat = slopes.shape[-2], F.reshape(-1)  # (flat places: the coupled arm's slopes are one group's)
        if slopes.ndim == 2:  # the arm's, coupled
            flat[at.flat_model_slopes] = slopes[:, :read].reshape(-1)  # [q; v] by [q; v]
        else:
            F[:, :2, :2] = slopes
        if self.estimates_disturbance:
            b = np.zeros(self.joint_count) if self._own_inverse_mass is None else self._own_inverse_mass
            if self._per_group == 1:  # every group's
                F[at.q_by_d], F[at.v_by_d] = 0.5 * b * dt * dt, b * dt
            else:
                flat[at.flat_q_by_d], flat[at.flat_v_by_d] = 0.5 * b * dt * dt, b * dt
            if slopes.shape[-1] > slopes.shape[-2]:  # the model's own slopes per rad/s² pushed on each joint
                flat[at.flat_model_by_d] = (slopes[:, read:] * b).reshape(-1)
        return F

    def _start(self, joints: np.ndarray, z: np.ndarray) -> None:
        """Start ``joints`` afresh from the reading ``z``: ``d`` 0, no correlation with the other joints, and no
        jump taken until the readings have agreed a while (after a fault they can be far from any model)."""
        m, k = self.size, self._per_group
        self.x[joints] = 0.0
        self.x[joints, :2] = z[joints]
        prior = np.zeros((m, m))
        prior[:2, :2] = self.R
        if self.estimates_disturbance:
            prior[2, 2] = DISTURBANCE_PRIOR_STD_NM**2
        for j in np.flatnonzero(joints):
            if self._R_joint is not None:  # the reading's own σ; its velocity is the prediction's, unread
                prior[0, 0] = self._R_joint[j, 0, 0]
                prior[1, 1] = UNREAD_VELOCITY_START_STD**2
                if self.estimates_disturbance:
                    prior[2, 2] = UNREAD_DISTURBANCE_START_STD**2
            group, first = divmod(j, k)
            own = slice(first * m, (first + 1) * m)
            self.P[group, own, :] = 0.0
            self.P[group, :, own] = 0.0
            self.P[group, own, own] = prior
            if self.estimates_disturbance:
                self.P[group, first * m + 2, first * m + 2] *= self._torque_scale[j] ** 2
        # Unproven: followed until they agree; a camera's (no velocity, slower) as agreeing: followed, its noise swings
        self._distance_sq_average[joints] = innovation.UNPROVEN_DISTANCE_SQ if self._R_joint is None else MISMATCH_FROM
        self._external = None

    def _noise_variances(self) -> tuple[np.ndarray, np.ndarray]:
        """Per joint, the variances in force this period (disturbance (N·m)²/s, acceleration (rad/s²)²): the σs
        squared."""
        if all((self._distance_sq_average <= innovation.MISMATCH_FROM).tolist()):  # every joint agrees
            return self._agreeing_variances
        sigma_d, sigma_a = innovation.noise_in_force(self._distance_sq_average, self._agreeing_std, self._mismatch_std)
        return np.square(sigma_d * self._torque_scale), np.square(sigma_a)

    def predict(
        self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray, horizon_s: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """The state ``horizon_s`` s ahead under ``torque`` (N·m) and the external torque as estimated now."""
        q, v = np.array(position, dtype=float), np.array(velocity, dtype=float)
        if horizon_s <= 0:
            return q, v
        step, external = self.config.model_step_s, self._disturbance_torque()
        return self.predictor(q, v, torque, horizon_s, max_step_s=step, external_nm=external)

    def velocity_at_instant(self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray) -> np.ndarray:
        """The velocity at the state's instant: the mean of the model step's that ended there (the state's own)
        and the one that starts there (what a reference's velocity at that instant compares with)."""
        h = self.config.model_step_s
        _, ahead = self.predictor(position, velocity, torque, h, max_step_s=h, external_nm=self._disturbance_torque())
        return 0.5 * (velocity + ahead)
