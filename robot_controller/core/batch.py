"""Many controllers at once: the one-joint arm's :class:`~robot_controller.core.model.JointArmModel`
stepped over a batch, closed by the same :class:`~robot_controller.core.laws.pid.Pid` law the nodes run
(its arrays broadcast over the batch). For sweeps and tuning: thousands of gain sets simulated together,
far faster than real time; a test checks the model's motion against MuJoCo's.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from robot_controller.core.estimation import JointKalmanFilter, KalmanConfig
from robot_controller.core.laws.pid import Pid, PidConfig
from robot_controller.core.model import JointArmModel, SensorConfig, measure
from robot_controller.core.reference import Trajectory


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
    model: JointArmModel,
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
    """Simulate every gain set of ``pid_config`` (arrays of shape ``(batch, 1)``) on the one-joint ``model``
    (physics steps of ``physics_dt``) with the controller's own PID code, the sensor's noise and the torque
    limit; with feedforward ``none``, ``gravity`` or ``full`` and, if given, the Kalman filter (the core's own,
    predicting with ``model``). With ``common_noise`` every gain set meets the same noise. Returns each one's
    tracking RMS on the true angle, rad."""
    if len(model.joint_names) != 1:
        raise ValueError("the batch runs a one-joint arm")
    batch = np.broadcast_shapes(pid_config.kp.shape, pid_config.ki.shape, pid_config.kd.shape)[0]
    q, v_true = np.zeros((batch, 1)), np.zeros((batch, 1))
    pid = Pid(pid_config)
    noise = CommonNoise(rng) if common_noise else rng
    filter_ = None
    if kalman is not None:
        config = replace(kalman, model_step_s=physics_dt)
        filter_ = JointKalmanFilter(config, batch, model.predict, transition=model.transition, independent_joints=True)
    n_steps = int(round(control_period_s / physics_dt))
    applied = np.zeros((batch, 1))
    squared = np.zeros((batch, 1))
    scored = 0
    for k in range(int(round(duration_s / control_period_s))):
        t = k * control_period_s
        p, v, a = (np.broadcast_to(x, (batch, 1)) for x in trajectory.sample(t))
        q_meas, v_meas = measure(sensor, q, v_true, noise)
        if filter_ is not None:
            q_f, v_f = filter_.update(t, q_meas[:, 0], v_meas[:, 0], applied[:, 0])
            v_f = filter_.velocity_at_instant(q_f, v_f, applied[:, 0])
            q_meas, v_meas = q_f[:, None], v_f[:, None]
        if feedforward == "full":
            ff = model.torque(p, v, a)
        elif feedforward == "gravity":
            ff = model.gravity(p)
        else:
            ff = 0.0
        terms = pid.step(control_period_s, p, v, q_meas, v_meas, ff)
        if t >= warmup_s:
            squared += (p - q) ** 2
            scored += 1
        applied = np.clip(terms.command, -torque_max, torque_max)
        q, v_true = model.steps(q, v_true, applied, physics_dt, n_steps)
    return np.sqrt(squared[:, 0] / max(scored, 1))
