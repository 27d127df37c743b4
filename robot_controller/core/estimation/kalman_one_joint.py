"""The Kalman filter's update of a running one-joint filter on Python floats
(:class:`OneJointPath`, a part of :class:`~robot_controller.core.estimation.estimator.JointKalmanFilter`):
on arrays of one to three values NumPy's per-call cost is most of the work, and one
joint is the tutorial's arm and the batch's gain sets. The same arithmetic as the array
path (:mod:`robot_controller.core.estimation.kalman_arrays`), in the same order."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Protocol

import numpy as np

from robot_controller.core.estimation import innovation
from robot_controller.core.estimation.kalman_config import DISTURBANCE_PRIOR_STD_NM
from robot_controller.core.model import step_count

if TYPE_CHECKING:
    from robot_controller.core.estimation.estimator import JointKalmanFilter


def _inverse_2x2(a: float, b: float, c: float, d: float) -> tuple[float, float, float, float]:
    """:func:`inverse_2x2` of one matrix ``[[a, b], [c, d]]``, row by row, on floats."""
    det = a * d - b * c
    return d / det, -b / det, -c / det, a / det


def _power_2x2(a: list[float], k: int) -> tuple[float, float, float, float]:
    """:func:`~robot_controller.core.arrays.matrix_power` of a 2 × 2 matrix given row by
    row (``[a00, a01, a10, a11]``), ``k >= 1``, on floats: the same products in the same
    order (binary powering; up to the cube, as it takes them)."""
    a00, a01, a10, a11 = a
    if k <= 3:
        if k == 1:
            return a00, a01, a10, a11
        s00, s01, s10, s11 = a00 * a00 + a01 * a10, a00 * a01 + a01 * a11, a10 * a00 + a11 * a10, a10 * a01 + a11 * a11
        if k == 2:
            return s00, s01, s10, s11
        return s00 * a00 + s01 * a10, s00 * a01 + s01 * a11, s10 * a00 + s11 * a10, s10 * a01 + s11 * a11
    p00, p01, p10, p11 = a00, a01, a10, a11  # the power a^(2^i)
    result = None
    while True:
        k, bit = divmod(k, 2)
        if bit:
            if result is None:
                result = (p00, p01, p10, p11)
            else:
                r00, r01, r10, r11 = result
                result = (
                    r00 * p00 + r01 * p10,
                    r00 * p01 + r01 * p11,
                    r10 * p00 + r11 * p10,
                    r10 * p01 + r11 * p11,
                )
        if k == 0:
            return result
        p00, p01, p10, p11 = p00 * p00 + p01 * p10, p00 * p01 + p01 * p11, p10 * p00 + p11 * p10, p10 * p01 + p11 * p11


class OneJointModel(Protocol):
    """The arm model of one joint on Python floats (as
    :class:`~robot_controller.core.model.arm_dynamics.OneJointDynamics` answers it)."""

    mass: float  #: kg·m², the joint's inertia (constant: one joint turns the whole arm rigidly)

    def predict(
        self, position: float, velocity: float, torque: float, horizon_s: float, max_step_s: float, external_nm=None
    ) -> tuple[float, float]: ...

    def step_slopes(self, position: float, velocity: float, torque: float, step_s: float) -> list[float]: ...


class _ArrayCalls:
    """A one-joint filter's arm model through its array callables (the predictor, the step
    Jacobian or finite differences, the mass matrix), floats in and out: for a model
    without a :class:`OneJointModel`."""

    mass = None  #: M(q) is asked at each q

    def __init__(self, kalman: JointKalmanFilter) -> None:
        self._kalman = kalman

    def predict(
        self, position: float, velocity: float, torque: float, horizon_s: float, max_step_s: float, external_nm=None
    ) -> tuple[float, float]:
        q, v = self._kalman.predictor(
            np.array([position]),
            np.array([velocity]),
            np.array([torque]),
            horizon_s,
            max_step_s=max_step_s,
            external_nm=None if external_nm is None else np.array([external_nm]),
        )
        return float(q[0]), float(v[0])

    def step_slopes(self, position: float, velocity: float, torque: float, step_s: float) -> list[float]:
        slopes = self._kalman._step_slopes(np.array([position]), np.array([velocity]), np.array([torque]), step_s)
        return np.asarray(slopes, dtype=float).ravel().tolist()


def _quadratic(u0: float, u1: float, a: float, b: float, c: float, d: float, w0: float, w1: float) -> float:
    """``uᵀ·[[a, b], [c, d]]·w`` for 2-vectors, on floats."""
    return u0 * (a * w0 + b * w1) + u1 * (c * w0 + d * w1)


class OneJointPath:
    """:meth:`~robot_controller.core.estimation.estimator.JointKalmanFilter.update` of a running
    one-joint filter, and the float forms of what it asks of the filter."""

    def _update_one_joint(
        self,
        time_s: float,
        position: np.ndarray,
        velocity: np.ndarray,
        torque: np.ndarray,
        torque_change: np.ndarray | None,
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`update` of a running one-joint filter, the same arithmetic on Python
        floats: on arrays of one to three values NumPy's per-call cost is most of the
        work. The arm model is asked through :attr:`_one_joint_calls` (floats in and
        out). The matrices' products are in the order :meth:`update` takes them, with
        the transition's known zeros and ones left out (exact); the covariances, symmetric,
        are worked out entry by entry on their upper triangle (to rounding, what the
        full products and the symmetrisation give)."""
        config, calls = self.config, self._one_joint_calls
        observer = self.estimates_disturbance
        dt = time_s - self.time_s
        self.time_s = time_s
        z_q, z_v = float(position[0]), float(velocity[0])
        tau = float(torque[0])
        state = self.x[0].tolist()
        q_now, v_now = state[0], state[1]
        # The transition F over the period: one model step's slopes, carried over the period's steps.
        steps = step_count(dt, config.model_step_s)
        f00, f01, f10, f11 = _power_2x2(calls.step_slopes(q_now, v_now, tau, dt / steps), steps)
        sigma_d, sigma_a = self._one_joint_noise_in_force()
        timing_uncertain = (
            torque_change is not None and config.command_timing_uncertainty_s > 0 and self.mass_matrix is not None
        )
        if observer:
            b_before = 0.0 if self._own_inverse_mass is None else self._own_inverse_mass.item()
            f02, f12 = 0.5 * b_before * dt * dt, b_before * dt  # d moves the arm as a torque there would
        external = self._one_joint_disturbance_torque()
        q_pred, v_pred = calls.predict(q_now, v_now, tau, dt, config.model_step_s, external)
        b = 0.0
        if observer or timing_uncertain:
            self._set_mass(q_now)
            b = self._own_inverse_mass.item()  # rad/s² per N·m
        # The process noise, as :func:`process_noise` and :meth:`update` weigh it (its upper
        # triangle, q00 = Q[0][0], q01 = Q[0][1], ...; without the observer, zero where d would be).
        g0, g1 = 0.5 * dt * dt, dt
        variance_a = sigma_a * sigma_a
        if observer:
            qq, qv, vv, qd, vd = dt**5 / 20, dt**4 / 8, dt**3 / 3, dt**3 / 6, dt**2 / 2
            w = sigma_d * sigma_d
            wb = w * b
            wb2 = wb * b
            q00, q01, q02 = variance_a * (g0 * g0) + wb2 * qq, variance_a * (g0 * g1) + wb2 * qv, wb * qd
            q11, q12, q22 = variance_a * (g1 * g1) + wb2 * vv, wb * vd, w * dt
        else:
            q00, q01, q11 = g0 * g0 * variance_a, g0 * g1 * variance_a, g1 * g1 * variance_a
            q02 = q12 = q22 = 0.0
        if timing_uncertain:
            sigma_v = abs(float(torque_change[0])) * config.command_timing_uncertainty_s * b
            variance_v = sigma_v * sigma_v
            q00 += dt * dt * variance_v
            q01 += dt * variance_v
            q11 += variance_v
        # P_pred = F·P·Fᵀ + Q, symmetric (its upper triangle); F's last row is [0, 0, 1] (without
        # the observer, P is padded with zeros to 3 × 3: the same sums, exactly).
        if observer:
            (p00, p01, p02), (_, p11, p12), (_, _, p22) = self.P[0].tolist()
        else:
            (p00, p01), (_, p11) = self.P[0].tolist()
            f02 = f12 = p02 = p12 = p22 = 0.0
        r00, r01, r02 = (
            f00 * p00 + f01 * p01 + f02 * p02,
            f00 * p01 + f01 * p11 + f02 * p12,
            f00 * p02 + f01 * p12 + f02 * p22,
        )
        r10, r11, r12 = (
            f10 * p00 + f11 * p01 + f12 * p02,
            f10 * p01 + f11 * p11 + f12 * p12,
            f10 * p02 + f11 * p12 + f12 * p22,
        )
        a00 = r00 * f00 + r01 * f01 + r02 * f02 + q00
        a01 = r00 * f10 + r01 * f11 + r02 * f12 + q01
        a02 = r02 + q02
        a11 = r10 * f10 + r11 * f11 + r12 * f12 + q11
        a12 = r12 + q12
        a22 = p22 + q22
        r_q, r_v = self._r_diagonal
        surprise_q, surprise_v = z_q - q_pred, z_v - v_pred
        s00, s01, s11 = a00 + r_q, a01, a11 + r_v
        unexplainable = False
        if observer:
            limit = float(self.disturbance_limit[0])
            unexplainable = abs(surprise_v) > limit * (b * dt) + innovation.BEYOND_SIGMA * math.sqrt(s11)
        i00, i01, i10, i11 = _inverse_2x2(s00, s01, s01, s11)
        distance_sq = _quadratic(surprise_q, surprise_v, i00, i01, i10, i11, surprise_q, surprise_v)
        average = self._distance_sq_average.item()
        jumped = False
        if observer and config.jump_detection_sigma > 0:
            step_q, step_v = 0.5 * b * dt * dt, b * dt
            along = _quadratic(step_q, step_v, i00, i01, i10, i11, surprise_q, surprise_v)
            weight = _quadratic(step_q, step_v, i00, i01, i10, i11, step_q, step_v)
            explained = along**2 / weight
            jumped = (
                average < innovation.MISMATCH_FROM
                and explained > config.jump_detection_sigma**2
                and distance_sq - explained < innovation.JUMP_RESIDUAL_MAX
            )
            if jumped:  # the covariance of a jump of d at the start of the period, G·Gᵀ·σ², G = [step_q, step_v, 1]
                jump_std = DISTURBANCE_PRIOR_STD_NM * (1.0 if self._torque_scale is None else self._torque_scale[0])
                jump_variance = float(jump_std**2)
                a00 += jump_variance * (step_q * step_q)
                a01 += jump_variance * (step_q * step_v)
                a02 += jump_variance * step_q
                a11 += jump_variance * (step_v * step_v)
                a12 += jump_variance * step_v
                a22 += jump_variance
                self.jump_count[0] += 1
                s00, s01, s11 = a00 + r_q, a01, a11 + r_v
                i00, i01, i10, i11 = _inverse_2x2(s00, s01, s01, s11)
        if not jumped:
            average += min(1.0, dt / innovation.CONSISTENCY_TIME_S) * (distance_sq - average)
            self._distance_sq_average = np.array([average])
        # The gain K = (S⁻¹·P_read)ᵀ, P_read the rows of the readings (q and v): per state, the gain
        # on the position reading (k_q) and on the velocity reading (k_v).
        kq0, kq1, kq2 = i00 * a00 + i01 * a01, i00 * a01 + i01 * a11, i00 * a02 + i01 * a12
        kv0, kv1, kv2 = i10 * a00 + i11 * a01, i10 * a01 + i11 * a11, i10 * a02 + i11 * a12
        q_new = q_pred + (kq0 * surprise_q + kv0 * surprise_v)
        v_new = v_pred + (kq1 * surprise_q + kv1 * surprise_v)
        # P − K·P_read, symmetric (its upper triangle).
        n00, n01, n11 = a00 - (kq0 * a00 + kv0 * a01), a01 - (kq0 * a01 + kv0 * a11), a11 - (kq1 * a01 + kv1 * a11)
        if observer:
            d_new = min(max(state[2] + (kq2 * surprise_q + kv2 * surprise_v), -limit), limit)
            n02, n12 = a02 - (kq0 * a02 + kv0 * a12), a12 - (kq1 * a02 + kv1 * a12)
            n22 = a22 - (kq2 * a02 + kv2 * a12)
            self.x = np.array([[q_new, v_new, d_new]])
            self.P = np.array([[[n00, n01, n02], [n01, n11, n12], [n02, n12, n22]]])
        else:
            self.x = np.array([[q_new, v_new]])
            self.P = np.array([[[n00, n01], [n01, n11]]])
        if unexplainable:
            self._start(np.ones(1, dtype=bool), np.array([[z_q, z_v]]))
            self.restart_count += 1
            return self.x[:, 0].copy(), self.x[:, 1].copy()
        return np.array([q_new]), np.array([v_new])

    def _one_joint_disturbance_torque(self) -> float | None:
        """:meth:`_disturbance_torque` of a one-joint filter, as a float."""
        if not self.estimates_disturbance or self.x is None or self._mass is None:
            return None
        return self._mass.item() * (self._own_inverse_mass.item() * self.x.item(0, 2))

    def _one_joint_noise_in_force(self) -> tuple[float, float]:
        """:meth:`_noise_in_force` of a one-joint filter, as floats."""
        average = float(self._distance_sq_average[0])
        near_d, near_a = self._agreeing_std_floats
        if average <= innovation.MISMATCH_FROM:
            sigma_d, sigma_a = near_d, near_a
        else:
            far_d, far_a = self._mismatch_std_floats
            w = min(max((average - innovation.MISMATCH_FROM) / innovation.MISMATCH_SPAN, 0.0), 1.0)
            sigma_d = math.sqrt(near_d * near_d + w * (far_d * far_d - near_d * near_d))
            sigma_a = math.sqrt(near_a * near_a + w * (far_a * far_a - near_a * near_a))
        if self._torque_scale is not None:
            sigma_d *= float(self._torque_scale[0])
        return sigma_d, sigma_a
