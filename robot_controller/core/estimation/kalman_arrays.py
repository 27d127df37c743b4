"""The Kalman filter's update on arrays, any number of joints (:class:`ArrayPath`, a part
of :class:`~robot_controller.core.estimation.estimator.JointKalmanFilter`): the path of an arm
of several joints, of the batch's independent joints, and of any filter's first
reading; with the restart from a reading and the allowance for a jump of the external
torque, which the one-joint path shares."""

from __future__ import annotations

import numpy as np

from robot_controller.core.arrays import within
from robot_controller.core.estimation import innovation
from robot_controller.core.estimation.kalman_config import DISTURBANCE_PRIOR_STD_NM, process_noise


def inverse_2x2(A: np.ndarray) -> np.ndarray:
    """The inverses of a stack of 2 × 2 matrices ``(..., 2, 2)``, in closed form
    (adjugate over determinant): what ``np.linalg.inv`` gives to rounding, at a
    fraction of the cost of a LAPACK call per filter update."""
    a, b, c, d = A[..., 0, 0], A[..., 0, 1], A[..., 1, 0], A[..., 1, 1]
    det = a * d - b * c
    inverse = np.empty_like(A)
    inverse[..., 0, 0], inverse[..., 0, 1] = d / det, -b / det
    inverse[..., 1, 0], inverse[..., 1, 1] = -c / det, a / det
    return inverse


def _solve_symmetric(S: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``S⁻¹·B`` for the symmetric positive definite innovation covariance ``S``:
    by :func:`inverse_2x2` for one joint's readings, otherwise by LAPACK."""
    if S.shape == (2, 2):
        return inverse_2x2(S).dot(B)
    return np.linalg.solve(S, B)


class _StateIndex:
    """Where each joint's quantities sit in the filter's state ``[q1, v1, (d1), q2, v2, ...]``
    (``m`` per joint) and its covariance: index arrays made once per filter, so that
    each update picks and places blocks with one indexing operation apiece."""

    def __init__(self, n: int, m: int) -> None:
        first = np.arange(n) * m
        self.q, self.v, self.d = first, first + 1, first + 2  #: each joint's q, v and (m = 3) d
        rows = first[:, None, None] + np.arange(m)[:, None]
        #: each joint's own (m, m) block of the covariance: ``P[blocks]`` is (n, m, m)
        self.blocks = (rows, rows.transpose(0, 2, 1))
        read_rows = rows[:, :2, :2]
        #: each joint's own reading block (q and v): ``P[own_readings]`` is (n, 2, 2)
        self.own_readings = (read_rows, read_rows.transpose(0, 2, 1))
        read = np.stack([self.q, self.v], axis=-1).reshape(-1)
        #: every reading by every reading, ``P[readings]`` is (2n, 2n) in reading order
        self.readings = np.ix_(read, read)
        qv = np.concatenate([self.q, self.v])
        #: where the model's slopes, ``[q1..qn, v1..vn]`` by the same, go in the transition
        self.model_slopes = np.ix_(qv, qv)


class ArrayPath:
    """:meth:`~robot_controller.core.estimation.estimator.JointKalmanFilter.update` on arrays and the
    steps it shares with the one-joint path."""

    def _update_joints(
        self,
        time_s: float,
        position: np.ndarray,
        velocity: np.ndarray,
        torque: np.ndarray,
        torque_change: np.ndarray | None = None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`update` on arrays, any number of joints."""
        n, m = self.joint_count, self.size
        z = np.empty((n, 2))  # the reading, per joint
        z[:, 0], z[:, 1] = position, velocity
        g, k = self._groups, self._per_group
        if self.x is None or self.time_s is None or not (0 < time_s - self.time_s < 1.0):
            self.x = np.zeros((n, m))
            self.P = np.zeros((g, k * m, k * m))
            if self.estimates_disturbance:
                self._set_mass(position)
            self._start(np.ones(n, dtype=bool), z)
            self.time_s = time_s
            return position.copy(), velocity.copy()
        dt = time_s - self.time_s
        self.time_s = time_s
        q, v = self.x[:, 0], self.x[:, 1]
        F = self._transition(q, v, torque, dt)
        sigma_d, sigma_a = self._noise_in_force()
        timing_uncertain = (
            torque_change is not None and self.config.command_timing_uncertainty_s > 0 and self.mass_matrix is not None
        )
        q_pred, v_pred = self._step_model(q, v, torque, dt)  # with the external torque of the last estimate
        if self.estimates_disturbance or timing_uncertain:
            self._set_mass(q)
            b = self._own_inverse_mass  # rad/s² per N·m on each joint's own axis
        if not self.estimates_disturbance:
            G = np.array([0.5 * dt * dt, dt])
            Q = np.outer(G, G) * (sigma_a**2)[:, None, None]
        else:
            Q = process_noise(self.config, dt, b, sigma_d, sigma_a)
        if timing_uncertain:
            # A velocity step of unknown size (the change acting that much sooner or later) early in the span.
            sigma_v = np.abs(torque_change) * self.config.command_timing_uncertainty_s * b
            G = np.array([dt, 1.0])
            Q[:, :2, :2] += np.outer(G, G) * (sigma_v**2)[:, None, None]
        x_pred = self.x.copy()
        x_pred[:, 0], x_pred[:, 1] = q_pred, v_pred
        P_pred = np.matmul(np.matmul(F, self.P), F.transpose(0, 2, 1))
        P_pred[(slice(None), *self._index.blocks)] += Q.reshape(g, k, m, m)  # each joint's own process noise
        surprise = z - x_pred[:, :2]  # the innovation, per joint
        S_joint = self._joint_blocks(P_pred)  # each joint's own (n, 2, 2)
        unexplainable = None
        if self.estimates_disturbance:
            unexplainable = innovation.beyond_any_disturbance(surprise, S_joint, b * dt, self.disturbance_limit)
        S_inv = inverse_2x2(S_joint)
        distance_sq = np.einsum("ni,nij,nj->n", surprise, S_inv, surprise)
        jumped = np.zeros(n, dtype=bool)
        if self.estimates_disturbance and self.config.jump_detection_sigma > 0:
            step = np.empty((n, 2))  # the reading's change per N·m of a step
            step[:, 0], step[:, 1] = 0.5 * b * dt * dt, b * dt
            jumped = innovation.agreeing(self._distance_sq_average) & innovation.looks_like_a_jump(
                surprise, S_inv, distance_sq, step, self.config.jump_detection_sigma
            )
            P_pred = self._allow_jumps(P_pred, jumped, b, dt)
        self._distance_sq_average = innovation.updated_average(self._distance_sq_average, distance_sq, jumped, dt)
        P_read = P_pred[:, self._read, :]  # (g, 2k, km)
        if k == 1 and not jumped.any():  # S is each joint's own block, inverted above
            K = np.matmul(S_inv, P_read).transpose(0, 2, 1)  # (g, m, 2)
        else:
            S = P_pred[(slice(None), *self._index.readings)] + self._R_all
            K = (inverse_2x2(S) @ P_read if k == 1 else np.linalg.solve(S, P_read)).transpose(0, 2, 1)
        gain = np.matmul(K, surprise.reshape(g, 2 * k, 1))[:, :, 0]
        self.x = (x_pred.reshape(g, k * m) + gain).reshape(n, m)
        self.P = P_pred - np.matmul(K, P_read)
        self.P = 0.5 * (self.P + self.P.transpose(0, 2, 1))
        if self.estimates_disturbance:
            within(self.x[:, 2], self.disturbance_limit, out=self.x[:, 2])
            if unexplainable.any():
                self._start(unexplainable, z)
                self.restart_count += unexplainable
        return self.x[:, 0].copy(), self.x[:, 1].copy()

    def _joint_blocks(self, P: np.ndarray) -> np.ndarray:
        """Each joint's reading covariance (n, 2, 2): its own block of ``P`` plus the sensor's."""
        return P[(slice(None), *self._index.own_readings)].reshape(self.joint_count, 2, 2) + self.R

    def _start(self, joints: np.ndarray, z: np.ndarray) -> None:
        """Start the filter of ``joints`` (bool per joint) afresh from the reading ``z`` (n, 2):
        the state the reading, the external torque 0, no correlation with the other joints.
        Trust is earned: a (re)started filter follows its readings, and takes no jump, until
        they have agreed with it for a while (about 0.2 s). After a fault (a frozen node, a
        brake that held the arm a little longer than reported) the first readings can be far
        from any model, and one taken as a jump would command the full torque the wrong way."""
        m, k = self.size, self._per_group
        self.x[joints] = 0.0
        self.x[joints, :2] = z[joints]
        prior = np.zeros((m, m))
        prior[:2, :2] = self.R
        if self.estimates_disturbance:
            prior[2, 2] = DISTURBANCE_PRIOR_STD_NM**2
        if k == 1:  # each joint its own group: its whole covariance is the prior
            self.P[joints] = prior
            if self.estimates_disturbance and self._torque_scale is not None:
                self.P[joints, 2, 2] *= self._torque_scale[joints] ** 2
        else:
            rows = (np.flatnonzero(joints)[:, None] * m + np.arange(m)[None, :]).reshape(-1)
            self.P[0, rows, :] = 0.0
            self.P[0, :, rows] = 0.0
            for j in np.flatnonzero(joints):
                self.P[0, j * m : (j + 1) * m, j * m : (j + 1) * m] = prior
                if self.estimates_disturbance and self._torque_scale is not None:
                    self.P[0, j * m + 2, j * m + 2] *= self._torque_scale[j] ** 2
        self._distance_sq_average[joints] = innovation.UNPROVEN_DISTANCE_SQ

    def _noise_in_force(self) -> tuple[np.ndarray, np.ndarray]:
        """Per joint, the σ in force this period (disturbance N·m/√s, acceleration rad/s²):
        :func:`innovation.noise_in_force` at the readings' agreement so far."""
        sigma_d, sigma_a = innovation.noise_in_force(self._distance_sq_average, self._agreeing_std, self._mismatch_std)
        return (sigma_d if self._torque_scale is None else sigma_d * self._torque_scale), sigma_a

    def _allow_jumps(self, P_pred: np.ndarray, jumped: np.ndarray, b: np.ndarray, dt: float) -> np.ndarray:
        """For each joint whose reading is taken as a jump (``jumped``), add to
        the predicted covariance that of a jump of its external torque at the
        start of the period (σ DISTURBANCE_PRIOR_STD_NM, carried through the
        period as the torque moves the arm), so that the reading's surprise goes
        to the torque and the state it moved, not to noise. A push then costs
        one or two periods; without it, a filter whose torque may change only
        slowly would take tenths of a second."""
        if jumped.any():
            P_pred = P_pred.copy()
            m = self.size
            k = self._per_group
            for j in np.flatnonzero(jumped):
                G = np.array([0.5 * b[j] * dt * dt, b[j] * dt, 1.0])
                jump_std = DISTURBANCE_PRIOR_STD_NM * (1.0 if self._torque_scale is None else self._torque_scale[j])
                group, at = divmod(j, k)
                P_pred[group, at * m : (at + 1) * m, at * m : (at + 1) * m] += jump_std**2 * np.outer(G, G)
            self.jump_count += jumped
        return P_pred
