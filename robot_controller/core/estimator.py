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
surprise is in :mod:`robot_controller.core.innovation`.

Longer than our ~250-line guideline: the filter with and without the
disturbance state, its linearised covariance and the uses of its surprise.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import Protocol

import numpy as np

from robot_controller.core import innovation
from robot_controller.core.arm_model import step_count
from robot_controller.core.arrays import matrix_power, within
from robot_controller.core.errors import ConfigError

# Finite-difference steps for the model's slopes, rad and rad/s.
_BUMP_Q, _BUMP_V = 1e-6, 1e-5

# (q, v, torque, horizon_s, max_step_s=, external_nm=) → predicted (q, v): the arm model's ``predict``
Predictor = Callable[..., tuple[np.ndarray, np.ndarray]]
# (q, v, torque, step_s) → one model step's ∂[q'; v']/∂[q; v], (2n, 2n)
StepJacobian = Callable[[np.ndarray, np.ndarray, np.ndarray, float], np.ndarray]
# q → the arm's mass matrix M(q), (n, n), kg·m²
MassMatrix = Callable[[np.ndarray], np.ndarray]

# N·m, σ of the disturbance estimate when the filter (re)starts: nothing is known
# of it yet, so the first readings set it (a couple of periods).
DISTURBANCE_PRIOR_STD_NM = 2.0


@dataclass(frozen=True)
class KalmanConfig:
    """:param position_noise_std: measurement σ on position, rad
    :param velocity_noise_std: measurement σ on velocity, rad/s
    :param acceleration_noise_std: σ of the unmodelled acceleration, rad/s²
    :param disturbance_noise_std: how fast the external torque may change, N·m/√s
        (σ of its random walk; used only when the filter estimates it)
    """

    position_noise_std: float = 0.005
    velocity_noise_std: float = 0.02
    acceleration_noise_std: float = 0.005
    #: s, the longest step the arm model is integrated in between two readings: the plant's own
    #: (the simulator's physics step, 1 ms in the reference scenario), so that the prediction and
    #: the readings agree (a coarser step puts the predicted position off by about a·T·step/2)
    model_step_s: float = 0.001
    disturbance_noise_std: float = 0.0001
    #: a reading this many σ (Mahalanobis distance of its innovation) from the prediction, among
    #: readings that otherwise agree with the filter, is taken as a sudden external torque (a push, a
    #: collision, a load let go): the observer allows its torque a jump (σ DISTURBANCE_PRIOR_STD_NM)
    #: that period and follows it within a period or two, while between jumps the torque may change
    #: only slowly (disturbance_noise_std). 0: never.
    jump_detection_sigma: float = 5.0
    #: the σ the filter moves to while its readings disagree with it (an arm unlike its model,
    #: readings later than their stamps): it then follows the readings rather than its model
    mismatch_acceleration_noise_std: float = 2.0
    mismatch_disturbance_noise_std: float = 0.3
    #: s, how uncertain the instant is from which a new command acts on the arm: 0 where commands take
    #: effect on a known schedule (lockstep, the in-process loop); on the wall clock, the command path's
    #: latency and its jitter. A change of command Δτ then leaves the velocity uncertain by Δτ·this/inertia.
    command_timing_uncertainty_s: float = 0.0

    def __post_init__(self) -> None:
        for name in (
            "position_noise_std",
            "velocity_noise_std",
            "acceleration_noise_std",
            "model_step_s",
            "disturbance_noise_std",
            "mismatch_acceleration_noise_std",
            "mismatch_disturbance_noise_std",
        ):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ConfigError(f"{name}: must be a finite number > 0, got {value}")
        if not np.isfinite(self.command_timing_uncertainty_s) or self.command_timing_uncertainty_s < 0:
            raise ConfigError(
                f"command_timing_uncertainty_s: must be a finite number ≥ 0, got {self.command_timing_uncertainty_s}"
            )
        if not np.isfinite(self.jump_detection_sigma) or self.jump_detection_sigma < 0:
            raise ConfigError(f"jump_detection_sigma: must be a finite number ≥ 0, got {self.jump_detection_sigma}")

    def for_inertia(self, torque_scale: float) -> KalmanConfig:
        """The filter with its torque figures (the observer's σs) ``torque_scale`` times larger: for a
        joint that much heavier than the one they were chosen for, the same in acceleration."""
        return replace(
            self,
            disturbance_noise_std=self.disturbance_noise_std * torque_scale,
            mismatch_disturbance_noise_std=self.mismatch_disturbance_noise_std * torque_scale,
        )

    def at_mismatch(self) -> KalmanConfig:
        """The filter as it is while its readings disagree with it (the most it moves to)."""
        return replace(
            self,
            acceleration_noise_std=max(self.acceleration_noise_std, self.mismatch_acceleration_noise_std),
            disturbance_noise_std=max(self.disturbance_noise_std, self.mismatch_disturbance_noise_std),
        )


def process_noise(
    config: KalmanConfig,
    dt: float,
    acceleration_per_nm: np.ndarray | None = None,
    disturbance_noise_std: np.ndarray | None = None,
    acceleration_noise_std: np.ndarray | None = None,
) -> np.ndarray:
    """The filter's process noise over ``dt`` s: ``(2, 2)`` on ``[q, v]`` from
    the white unmodelled acceleration; with ``acceleration_per_nm`` (rad/s² per
    N·m on each joint, shape ``(n,)``: the disturbance observer) ``(n, 3, 3)``
    on ``[q, v, d]``, adding the random walk of ``d`` carried through the double
    integrator over ``dt`` (the continuous model's, exactly)."""
    G = (0.5 * dt * dt, dt)
    if acceleration_per_nm is None:
        return np.outer(G, G) * config.acceleration_noise_std**2
    b = np.asarray(acceleration_per_nm, dtype=float).reshape(-1)
    sigma_a = config.acceleration_noise_std if acceleration_noise_std is None else acceleration_noise_std
    sigma_d = config.disturbance_noise_std if disturbance_noise_std is None else disturbance_noise_std
    # Per joint, Q = σa²·A + w·b²·B + w·b·C + w·D (w = σd²): one product with the templates.
    weights = np.empty((b.size, 4))
    weights[:, 0] = np.square(sigma_a)
    weights[:, 3] = w = np.square(sigma_d)
    weights[:, 2] = wb = w * b
    weights[:, 1] = wb * b
    return weights.dot(_noise_templates(dt)).reshape(b.size, 3, 3)


@lru_cache(maxsize=64)  # a filter's periods are a handful of roundings of one period
def _noise_templates(dt: float) -> np.ndarray:
    """The four parts of the process noise on ``[q, v, d]`` over ``dt`` s, flattened (4, 9):
    ``A``, the white acceleration through the double integrator (``G·Gᵀ``, G = [dt²/2, dt]);
    ``B``, ``C``, ``D``, the random walk of ``d`` carried through it, in ``[q, v]``, between
    ``[q, v]`` and ``d``, and in ``d`` itself (:func:`process_noise` weighs them). Shared
    between calls (cached): read only."""
    g0, g1 = 0.5 * dt * dt, dt
    qq, qv, vv = dt**5 / 20, dt**4 / 8, dt**3 / 3
    qd, vd = dt**3 / 6, dt**2 / 2
    templates = np.array(
        [
            [g0 * g0, g0 * g1, 0.0, g0 * g1, g1 * g1, 0.0, 0.0, 0.0, 0.0],
            [qq, qv, 0.0, qv, vv, 0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, qd, 0.0, 0.0, vd, qd, vd, 0.0],
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, dt],
        ]
    )
    templates.flags.writeable = False
    return templates


def steady_state_gain(
    config: KalmanConfig, inertia: float, damping: float, period_s: float, estimate_disturbance: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One joint's filter at rest, linear (``inertia·q̈ + damping·q̇ = τ (+ d)``,
    gravity's stiffness left out as at the horizontal), readings every
    ``period_s``, in steady state: its transition ``F`` and torque input ``B``
    over the period (exact, zero-order hold) and the Kalman gain ``L``
    (``m × 2``, m = 2, or 3 with the disturbance observer). For the delay
    margin of the loop the filter is part of."""
    from scipy.linalg import solve_discrete_are

    from robot_controller.core.lqr import discretise  # [∫e, e, ė]: its lower block is [q, v]

    A3, B3 = discretise(float(inertia), float(damping), float(period_s))
    m = 3 if estimate_disturbance else 2
    F = np.eye(m)
    F[:2, :2] = A3[1:, 1:]
    B = np.zeros((m, 1))
    B[:2] = B3[1:]
    if estimate_disturbance:
        F[:2, 2:] = B3[1:]  # d acts as the actuator's torque does
        Q = process_noise(config, period_s, np.array([1.0 / inertia]))[0]
    else:
        Q = process_noise(config, period_s)
    H = np.eye(2, m)
    R = np.diag([config.position_noise_std**2, config.velocity_noise_std**2])
    P = solve_discrete_are(F.T, H.T, Q, R)  # the predicted covariance
    L = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
    return F, B, L


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
    :class:`~robot_controller.core.plant.OneJointDynamics` answers it)."""

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


class JointKalmanFilter:
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

    def _step_slopes(self, q: np.ndarray, v: np.ndarray, torque: np.ndarray, h: float) -> np.ndarray:
        """One model step's ∂[q'; v']/∂[q; v] (2n × 2n): the model's own, or by finite differences."""
        if self.jacobian is not None:
            return self.jacobian(q, v, torque, h)
        n = self.joint_count
        q1, v1 = self.predictor(q, v, torque, h, max_step_s=h)
        slopes = np.zeros((2 * n, 2 * n))
        for k in range(2 * n):
            bump = _BUMP_Q if k < n else _BUMP_V
            dq, dv = np.zeros(n), np.zeros(n)
            (dq if k < n else dv)[k % n] = bump
            q2, v2 = self.predictor(q + dq, v + dv, torque, h, max_step_s=h)
            slopes[:n, k], slopes[n:, k] = (q2 - q1) / bump, (v2 - v1) / bump
        return slopes

    def _transition(self, q: np.ndarray, v: np.ndarray, torque: np.ndarray, dt: float) -> np.ndarray:
        """The model linearised at ``(q, v)`` over ``dt`` (nm × nm, joint by joint): one
        model step's slopes carried over the period's steps, every joint's on every
        joint's, gravity's stiffness (destabilising on one side of the arm's travel)
        and the damping included; with only the double integrator, a filter that trusts
        the model (a small acceleration_noise_std) lets its error grow where gravity
        pulls the arm away. ``d`` moves its own joint as a torque there would."""
        n, m = self.joint_count, self.size
        g, k = self._groups, self._per_group
        steps = step_count(dt, self.config.model_step_s)
        h = dt / steps
        F = np.zeros((g, k * m, k * m))
        at = self._index
        if g == 1:
            F[0][at.model_slopes] = matrix_power(self._step_slopes(q, v, torque, h), steps)  # [q; v] by [q; v]
        else:
            F[:, :2, :2] = np.linalg.matrix_power(self._own_slopes(q, v, torque, h), steps)
        if self.estimates_disturbance:
            b = self._own_inverse_mass if self._inverse_mass is not None else np.zeros(n)
            F[:, at.q, at.d] = (0.5 * b * dt * dt).reshape(g, k)
            F[:, at.v, at.d] = (b * dt).reshape(g, k)
            F[:, at.d, at.d] = 1.0
        return F

    def _own_slopes(self, q: np.ndarray, v: np.ndarray, torque: np.ndarray, h: float) -> np.ndarray:
        """Independent joints: each one's step slopes ∂[q'; v']/∂[q; v] (n, 2, 2), every joint
        bumped at once (none moves another)."""
        q1, v1 = self.predictor(q, v, torque, h, max_step_s=h)
        q2, v2 = self.predictor(q + _BUMP_Q, v, torque, h, max_step_s=h)
        q3, v3 = self.predictor(q, v + _BUMP_V, torque, h, max_step_s=h)
        slopes = np.empty((self.joint_count, 2, 2))
        slopes[:, 0, 0], slopes[:, 1, 0] = (q2 - q1) / _BUMP_Q, (v2 - v1) / _BUMP_Q
        slopes[:, 0, 1], slopes[:, 1, 1] = (q3 - q1) / _BUMP_V, (v3 - v1) / _BUMP_V
        return slopes

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
