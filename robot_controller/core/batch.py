"""Many controllers at once: an analytic model of the one-joint arm,
vectorised over a batch, closed by the same :class:`~robot_controller.core.pid.Pid`
law the nodes run (its arrays broadcast over the batch).

For sweeps and tuning: thousands of gain sets simulated together, far faster
than real time. The model's constants come from the URDF through MuJoCo, and
a test checks its motion against MuJoCo's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robot_controller.core.pid import Pid, PidConfig
from robot_controller.core.plant import ArmDynamics
from robot_controller.core.sensor_model import SensorConfig, measure
from robot_controller.core.trajectory import Trajectory


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


class AnalyticArmBatch:
    """``batch`` copies of the arm stepped together (semi-implicit Euler, like MuJoCo's default)."""

    def __init__(self, constants: ArmConstants, batch: int, physics_dt: float = 0.001) -> None:
        self.constants, self.physics_dt = constants, physics_dt
        self.q = np.zeros((batch, 1))
        self.v = np.zeros((batch, 1))

    def step(self, torque: np.ndarray, n_steps: int = 1) -> None:
        c, dt = self.constants, self.physics_dt
        for _ in range(n_steps):
            # Damping implicit, as MuJoCo's Euler integrator treats it.
            self.v = (self.v * c.inertia + dt * (torque - c.gravity_torque * np.cos(self.q))) / (
                c.inertia + dt * c.damping
            )
            self.q = self.q + dt * self.v


def run_batch(
    *,
    constants: ArmConstants,
    pid_config: PidConfig,
    trajectory: Trajectory,
    sensor: SensorConfig,
    rng: np.random.Generator,
    duration_s: float,
    control_period_s: float = 0.01,
    physics_dt: float = 0.001,
    torque_max: float = 10.0,
    warmup_s: float = 2.0,
) -> np.ndarray:
    """Simulate every gain set of ``pid_config`` (arrays of shape ``(batch, 1)``)
    with full feedforward; return each one's tracking RMS on the true angle, rad."""
    batch = np.broadcast_shapes(pid_config.kp.shape, pid_config.ki.shape, pid_config.kd.shape)[0]
    arm = AnalyticArmBatch(constants, batch, physics_dt)
    pid = Pid(pid_config)
    n_steps = int(round(control_period_s / physics_dt))
    ticks = int(round(duration_s / control_period_s))
    squared = np.zeros((batch, 1))
    scored = 0
    for k in range(ticks):
        t = k * control_period_s
        p, v, a = (np.broadcast_to(x, (batch, 1)) for x in trajectory.sample(t))
        q_meas, v_meas = measure(sensor, arm.q, arm.v, rng)
        terms = pid.step(control_period_s, p, v, q_meas, v_meas, constants.torque(p, v, a))
        if t >= warmup_s:
            squared += (p - arm.q) ** 2
            scored += 1
        arm.step(np.clip(terms.command, -torque_max, torque_max), n_steps)
    return np.sqrt(squared[:, 0] / max(scored, 1))
