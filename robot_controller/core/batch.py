"""Many controllers at once: an analytic model of the one-joint arm,
vectorised over a batch, closed by the same :class:`~robot_controller.core.laws.pid.Pid`
law the nodes run (its arrays broadcast over the batch).

For sweeps and tuning: thousands of gain sets simulated together, far faster
than real time. The model's constants come from the URDF through MuJoCo, and
a test checks its motion against MuJoCo's.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from robot_controller.core.estimation import JointKalmanFilter, KalmanConfig
from robot_controller.core.laws.pid import Pid, PidConfig
from robot_controller.core.model import ArmDynamics, SensorConfig, measure, step_count
from robot_controller.core.reference import Trajectory


@dataclass(frozen=True)
class ArmConstants:
    """One revolute joint: ``J q'' = τ − b q' − G cos q``."""

    inertia: float  #: kg·m² about the joint
    damping: float  #: N·m·s/rad
    gravity_torque: float  #: G, N·m (gravity torque with the link horizontal)

    @classmethod
    def from_dynamics(cls, dynamics: ArmDynamics) -> ArmConstants:
        if len(dynamics.joint_names) != 1:
            raise ValueError("the analytic arm models one joint")
        zero = np.zeros(1)
        return cls(
            float(dynamics.mass_matrix(zero)[0, 0]), float(dynamics.damping[0]), float(dynamics.gravity(zero)[0])
        )

    def acceleration(self, q: np.ndarray, v: np.ndarray, torque: np.ndarray) -> np.ndarray:
        return (torque - self.damping * v - self.gravity_torque * np.cos(q)) / self.inertia

    def torque(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """Inverse dynamics (feedforward)."""
        return self.inertia * a + self.damping * v + self.gravity_torque * np.cos(q)

    def steps(
        self, q: np.ndarray, v: np.ndarray, force: np.ndarray, h: float, count: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """``count`` semi-implicit Euler steps of ``h`` under ``force``, the damping implicit as MuJoCo's are."""
        for _ in range(count):
            v = (v * self.inertia + h * (force - self.gravity_torque * np.cos(q))) / (self.inertia + h * self.damping)
            q = q + h * v
        return q, v


class AnalyticArmBatch:
    """``batch`` copies of the arm stepped together (semi-implicit Euler, like MuJoCo's default)."""

    def __init__(self, constants: ArmConstants, batch: int, physics_dt: float = 0.001) -> None:
        self.constants, self.physics_dt = constants, physics_dt
        self.q = np.zeros((batch, 1))
        self.v = np.zeros((batch, 1))

    def step(self, torque: np.ndarray, n_steps: int = 1) -> None:
        self.q, self.v = self.constants.steps(self.q, self.v, torque, self.physics_dt, n_steps)


class CommonNoise:
    """A random generator whose ``normal`` draws ONE value per joint and gives it to every
    gain set of a batch: every set meets the same sensor noise (common random numbers),
    so the search compares gains, not noise realisations."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def normal(self, loc: float, scale: float, size: tuple[int, ...]) -> np.ndarray:
        return np.broadcast_to(self.rng.normal(loc, scale, (1, *size[1:])), size)

    def standard_normal(self, size: tuple[int, ...]) -> np.ndarray:
        """``size`` is ``(signals, batch, joints)`` (the sensor's position and velocity noise): one
        draw per signal and joint, shared by the batch."""
        return np.broadcast_to(self.rng.standard_normal((size[0], 1, *size[2:])), size)


def run_batch(
    *,
    constants: ArmConstants,
    pid_config: PidConfig,
    trajectory: Trajectory,
    sensor: SensorConfig,
    rng: np.random.Generator,
    duration_s: float,
    control_period_s: float = 0.01,
    torque_max: float = 10.0,
    feedforward: str = "full",
    kalman: KalmanConfig | None = None,
    common_noise: bool = False,
    warmup_s: float = 2.0,
    physics_dt: float = 0.001,
) -> np.ndarray:
    """Simulate every gain set of ``pid_config`` (arrays of shape ``(batch, 1)``) on the
    analytic arm with the controller's own PID code, the sensor's noise and the torque
    limit; with feedforward ``none``, ``gravity`` or ``full`` and, if given, the Kalman
    filter (the core's own, predicting with the analytic arm). With ``common_noise``
    every gain set meets the same noise. Returns each one's tracking RMS on the true
    angle, rad."""
    batch = np.broadcast_shapes(pid_config.kp.shape, pid_config.ki.shape, pid_config.kd.shape)[0]
    arm = AnalyticArmBatch(constants, batch, physics_dt)
    pid = Pid(pid_config)
    noise = CommonNoise(rng) if common_noise else rng
    filter_ = None
    if kalman is not None:

        def predict(
            q: np.ndarray,
            v: np.ndarray,
            torque: np.ndarray,
            horizon_s: float,
            max_step_s: float = physics_dt,
            external_nm: np.ndarray | None = None,
        ) -> tuple[np.ndarray, np.ndarray]:
            force = torque if external_nm is None else torque + external_nm
            steps = step_count(horizon_s, max_step_s)
            return constants.steps(q, v, force, horizon_s / steps, steps)

        filter_ = JointKalmanFilter(replace(kalman, model_step_s=physics_dt), batch, predict, independent_joints=True)
    n_steps = int(round(control_period_s / physics_dt))
    applied = np.zeros((batch, 1))
    squared = np.zeros((batch, 1))
    scored = 0
    for k in range(int(round(duration_s / control_period_s))):
        t = k * control_period_s
        p, v, a = (np.broadcast_to(x, (batch, 1)) for x in trajectory.sample(t))
        q_meas, v_meas = measure(sensor, arm.q, arm.v, noise)
        if filter_ is not None:
            q_f, v_f = filter_.update(t, q_meas[:, 0], v_meas[:, 0], applied[:, 0])
            v_f = filter_.velocity_at_instant(q_f, v_f, applied[:, 0])
            q_meas, v_meas = q_f[:, None], v_f[:, None]
        if feedforward == "full":
            ff = constants.torque(p, v, a)
        elif feedforward == "gravity":
            ff = constants.gravity_torque * np.cos(p)
        else:
            ff = 0.0
        terms = pid.step(control_period_s, p, v, q_meas, v_meas, ff)
        if t >= warmup_s:
            squared += (p - arm.q) ** 2
            scored += 1
        applied = np.clip(terms.command, -torque_max, torque_max)
        arm.step(applied, n_steps)
    return np.sqrt(squared[:, 0] / max(scored, 1))
