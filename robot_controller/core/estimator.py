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
``M(q)⁻¹·d``. Mostly the velocity reading tells ``d`` apart: a torque ``d``
held over a period T changes the velocity by ``d·T/I`` more than the model
says. The estimate is kept within ``±disturbance_limit`` (the controller's
torque limit: a larger one could not be compensated anyway) and starts from
0 whenever the filter does (:meth:`JointKalmanFilter.reset`).

Longer than our ~250-line guideline: the filter with and without the disturbance state, and its linearised covariance.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from robot_controller.core.errors import ConfigError

# Finite-difference steps for the model's slopes, rad and rad/s.
_BUMP_Q, _BUMP_V = 1e-6, 1e-5

# (q, v, torque, dt) → predicted (q, v)
Predictor = Callable[[np.ndarray, np.ndarray, np.ndarray, float], tuple[np.ndarray, np.ndarray]]
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
    acceleration_noise_std: float = 2.0
    #: s, the longest step the arm model is integrated in between two readings: the plant's own
    #: (the simulator's physics step, 1 ms in the reference scenario), so that the prediction and
    #: the readings agree (a coarser step puts the predicted position off by about a·T·step/2)
    model_step_s: float = 0.001
    disturbance_noise_std: float = 0.3

    def __post_init__(self) -> None:
        for name in (
            "position_noise_std",
            "velocity_noise_std",
            "acceleration_noise_std",
            "model_step_s",
            "disturbance_noise_std",
        ):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ConfigError(f"{name}: must be a finite number > 0, got {value}")


def process_noise(config: KalmanConfig, dt: float, acceleration_per_nm: np.ndarray | None = None) -> np.ndarray:
    """The filter's process noise over ``dt`` s: ``(2, 2)`` on ``[q, v]`` from
    the white unmodelled acceleration; with ``acceleration_per_nm`` (rad/s² per
    N·m on each joint, shape ``(n,)``: the disturbance observer) ``(n, 3, 3)``
    on ``[q, v, d]``, adding the random walk of ``d`` carried through the double
    integrator over ``dt`` (the continuous model's, exactly)."""
    G = np.array([0.5 * dt * dt, dt])
    Q2 = np.outer(G, G) * config.acceleration_noise_std**2
    if acceleration_per_nm is None:
        return Q2
    b = np.asarray(acceleration_per_nm, dtype=float).reshape(-1)
    w = config.disturbance_noise_std**2
    Q = np.zeros((b.size, 3, 3))
    Q[:, :2, :2] = Q2
    Q[:, 0, 0] += w * b * b * dt**5 / 20
    Q[:, 0, 1] += w * b * b * dt**4 / 8
    Q[:, 1, 1] += w * b * b * dt**3 / 3
    Q[:, 0, 2] += w * b * dt**3 / 6
    Q[:, 1, 2] += w * b * dt**2 / 2
    Q[:, 2, 2] += w * dt
    Q[:, 1, 0], Q[:, 2, 0], Q[:, 2, 1] = Q[:, 0, 1], Q[:, 0, 2], Q[:, 1, 2]
    return Q


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


class JointKalmanFilter:
    """Predict with the arm model, correct with each reading.

    :param estimate_disturbance: add the external torque ``d`` to the state
        (the disturbance observer); needs ``mass_matrix``
    :param mass_matrix: the arm's M(q) (what ``d`` accelerates)
    :param disturbance_limit: N·m per joint, the bound on ``|d|`` (none if None)
    """

    def __init__(
        self,
        config: KalmanConfig,
        joint_count: int,
        predictor: Predictor,
        *,
        estimate_disturbance: bool = False,
        mass_matrix: MassMatrix | None = None,
        disturbance_limit: np.ndarray | None = None,
    ) -> None:
        if estimate_disturbance and mass_matrix is None:
            raise ConfigError("disturbance_observer: needs the arm model's mass matrix")
        self.config = config
        self.predictor = predictor
        self.joint_count = joint_count
        self.estimates_disturbance = bool(estimate_disturbance)
        self.mass_matrix = mass_matrix
        self.disturbance_limit = (
            np.full(joint_count, np.inf)
            if disturbance_limit is None
            else np.broadcast_to(np.asarray(disturbance_limit, float), (joint_count,)).copy()
        )
        self.size = 3 if self.estimates_disturbance else 2
        self.x: np.ndarray | None = None  # (n, 2): q, v per joint; (n, 3): q, v, d
        self.P = np.zeros((joint_count, self.size, self.size))
        self.R = np.diag([config.position_noise_std**2, config.velocity_noise_std**2])
        self.time_s: float | None = None
        #: per joint, rad/s² per N·m of external torque on each joint ((n, n): M⁻¹ at the last estimate)
        self._inverse_mass: np.ndarray | None = None

    def reset(self) -> None:
        """Forget the state: the next reading starts the filter again (and the disturbance from 0)."""
        self.x = None
        self.time_s = None
        self._inverse_mass = None

    @property
    def disturbance(self) -> np.ndarray:
        """The estimated external torque on each joint, N·m (0 without the observer or a state)."""
        if not self.estimates_disturbance or self.x is None:
            return np.zeros(self.joint_count)
        return self.x[:, 2].copy()

    def _disturbance_acceleration(self) -> np.ndarray:
        """rad/s² the estimated external torque gives each joint (0 without one)."""
        if not self.estimates_disturbance or self.x is None or self._inverse_mass is None:
            return np.zeros(self.joint_count)
        return self._inverse_mass @ self.x[:, 2]

    def update(
        self, time_s: float, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Take a reading stamped ``time_s``; ``torque`` is what acted since the last one.

        Returns the filtered ``(position, velocity)``.
        """
        z = np.stack([position, velocity], axis=-1)  # (n, 2)
        m = self.size
        if self.x is None or self.time_s is None or not (0 < time_s - self.time_s < 1.0):
            self.x = np.zeros((self.joint_count, m))
            self.x[:, :2] = z
            self.P = np.zeros((self.joint_count, m, m))
            self.P[:, :2, :2] = self.R
            if self.estimates_disturbance:
                self.P[:, 2, 2] = DISTURBANCE_PRIOR_STD_NM**2
                self._inverse_mass = np.linalg.inv(self.mass_matrix(np.asarray(position, float)))
            self.time_s = time_s
            return position.copy(), velocity.copy()
        dt = time_s - self.time_s
        self.time_s = time_s
        q, v = self.x[:, 0], self.x[:, 1]
        F = np.zeros((self.joint_count, m, m))
        F[:, :2, :2] = self._transition(q, v, torque, dt)
        if not self.estimates_disturbance:
            Q = process_noise(self.config, dt)
        else:
            self._inverse_mass = np.linalg.inv(self.mass_matrix(q))
            b = np.diag(self._inverse_mass)  # rad/s² per N·m on each joint's own axis
            F[:, 0, 2] = 0.5 * b * dt * dt
            F[:, 1, 2] = b * dt
            F[:, 2, 2] = 1.0
            Q = process_noise(self.config, dt, b)
        q, v = self._step_model(q, v, torque, dt)
        x_pred = self.x.copy()
        x_pred[:, 0], x_pred[:, 1] = q, v
        P_pred = F @ self.P @ np.swapaxes(F, -1, -2) + Q
        S = P_pred[:, :2, :2] + self.R
        K = P_pred[:, :, :2] @ np.linalg.inv(S)  # (n, m, 2)
        self.x = x_pred + np.einsum("nij,nj->ni", K, z - x_pred[:, :2])
        KH = np.zeros((self.joint_count, m, m))
        KH[:, :, :2] = K
        self.P = (np.eye(m) - KH) @ P_pred
        if self.estimates_disturbance:
            self.P = 0.5 * (self.P + np.swapaxes(self.P, -1, -2))
            self.x[:, 2] = np.clip(self.x[:, 2], -self.disturbance_limit, self.disturbance_limit)
        return self.x[:, 0].copy(), self.x[:, 1].copy()

    def _step_model(
        self, q: np.ndarray, v: np.ndarray, torque: np.ndarray, horizon_s: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """The arm model over ``horizon_s`` under ``torque`` (and the estimated
        external torque, if any), in steps of at most ``model_step_s``."""
        steps = max(1, int(np.ceil(horizon_s / self.config.model_step_s - 1e-9)))
        h = horizon_s / steps
        extra = self._disturbance_acceleration() * h  # the velocity d adds per step (semi-implicit)
        for _ in range(steps):
            q, v = self.predictor(q, v, torque, h)
            if self.estimates_disturbance:
                v = v + extra
                q = q + extra * h
        return q, v

    def predict(
        self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray, horizon_s: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """The state ``horizon_s`` seconds ahead under the actuator's ``torque``
        (N·m) and the external torque as estimated now (a latency compensation
        or a coast on the model that agrees with the filter)."""
        if horizon_s <= 0:
            return np.array(position, dtype=float), np.array(velocity, dtype=float)
        return self._step_model(np.array(position, dtype=float), np.array(velocity, dtype=float), torque, horizon_s)

    def _transition(self, q: np.ndarray, v: np.ndarray, torque: np.ndarray, dt: float) -> np.ndarray:
        """Per joint, the model linearised at ``(q, v)`` over ``dt``: ``(n, 2, 2)``.
        The acceleration's slopes in q (gravity's stiffness, which is
        destabilising on one side of the arm's travel) and in v (damping), from
        one model step each; with only the double integrator, a filter that
        trusts the model (a small acceleration_noise_std) lets its error grow
        where gravity pulls the arm away."""
        h = self.config.model_step_s
        _, v0 = self.predictor(q, v, torque, h)
        F = np.zeros((self.joint_count, 2, 2))
        for j in range(self.joint_count):
            bump = np.zeros(self.joint_count)
            bump[j] = _BUMP_Q
            a_q = (self.predictor(q + bump, v, torque, h)[1][j] - v0[j]) / (h * _BUMP_Q)
            bump[j] = _BUMP_V
            a_v = (self.predictor(q, v + bump, torque, h)[1][j] - v0[j] - _BUMP_V) / (h * _BUMP_V)
            F[j] = [[1.0 + 0.5 * a_q * dt * dt, dt + 0.5 * a_v * dt * dt], [a_q * dt, 1.0 + a_v * dt]]
        return F

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
        _, ahead = self.predictor(position, velocity, torque, h)
        if self.estimates_disturbance:
            ahead = ahead + self._disturbance_acceleration() * h
        return 0.5 * (velocity + ahead)
