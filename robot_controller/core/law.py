"""The control law: which gains are in force (the PID's own, or for LQR a
discrete Riccati design that replaces them), a one-line account of them,
their delay margin, and one step of feedback plus model feedforward within
the torque limit.

Gains: Kp N·m/rad, Ki N·m/(rad·s), Kd N·m·s/rad; torques N·m; times s.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from robot_controller.core import lqr
from robot_controller.core.controller_config import ControllerConfig
from robot_controller.core.errors import ConfigError
from robot_controller.core.feedforward import feedforward_torque
from robot_controller.core.pid import DerivativeSource, Pid, PidConfig, PidTerms
from robot_controller.core.plant import ArmDynamics
from robot_controller.core.reference_at_tick import Reference


def law_config(config: ControllerConfig, dynamics: ArmDynamics | None, joint_count: int) -> PidConfig:
    """The PID settings the law runs with. For LQR, the gains come from a
    discrete Riccati design on each joint's ``[∫e, e, ė]`` at the control rate
    (with feedforward carrying the motion, the feedback is exactly a PID on
    velocity error with these gains)."""
    if config.controller_type == "pid":
        return config.pid
    if dynamics is None:
        raise ConfigError("controller_type lqr: needs the arm model (urdf_path)")
    inertia = np.diag(dynamics.mass_matrix(np.zeros(joint_count)))
    gains = np.array([lqr.design(inertia[j], dynamics.damping[j], config.control_period_s, np.array(config.lqr_q),
                                 config.lqr_r).K[0] for j in range(joint_count)])
    return replace(config.pid, ki=gains[:, 0], kp=gains[:, 1], kd=gains[:, 2],
                   derivative_source=DerivativeSource.VELOCITY_ERROR)


def _values(values: np.ndarray | tuple[float, ...]) -> str:
    return "[" + ", ".join(f"{float(v):.3g}" for v in np.atleast_1d(values)) + "]"


def describe_law(config: ControllerConfig, gains: PidConfig) -> str:
    """One line for a log or a status topic: the law, the gains in force with
    their units, the torque limit and the feedforward. In LQR mode it says so,
    and that the kp/ki/kd parameters are unused (the design replaced them)."""
    in_force = (f"Kp={_values(gains.kp)} N·m/rad, Ki={_values(gains.ki)} N·m/(rad·s), "
                f"Kd={_values(gains.kd)} N·m·s/rad, D on {gains.derivative_source.value}, "
                f"|torque| <= {_values(gains.output_limit)} N·m, feedforward {config.feedforward.value}")
    if config.controller_type == "lqr":
        return (f"LQR (q={_values(config.lqr_q)}, r={config.lqr_r:g}, designed at "
                f"{1.0 / config.control_period_s:g} Hz): {in_force}; the kp/ki/kd parameters are unused")
    return f"PID: {in_force}"


def delay_margin_periods(gains: PidConfig, dynamics: ArmDynamics | None, joint_count: int,
                         control_period_s: float) -> int | None:
    """Whole control periods of unaccounted delay the feedback with ``gains``
    survives on the worst joint, the arm linearised at rest (see
    :func:`lqr.delay_margin_periods`). None without the arm model."""
    if dynamics is None:
        return None
    inertia = np.diag(dynamics.mass_matrix(np.zeros(joint_count)))
    margins = []
    for j in range(joint_count):
        A, B = lqr.discretise(float(inertia[j]), float(dynamics.damping[j]), control_period_s)
        K = np.array([[gains.ki[j], gains.kp[j], gains.kd[j]]], dtype=float)
        margins.append(lqr.delay_margin_periods(A, B, K))
    return min(margins)


def law_step(pid: Pid, config: ControllerConfig, dynamics: ArmDynamics | None, dt_s: float,
             position: np.ndarray, velocity: np.ndarray, reference: Reference) -> PidTerms:
    """One step of the law over ``dt_s`` seconds: the model's feedforward torque
    for the reference motion plus the PID feedback on the error between the
    reference and the arm's ``position`` (rad) / ``velocity`` (rad/s), limited
    to the torque limit (and slew rate) by the PID. The feedforward is for
    ``reference.feedforward`` when it is given (the reference over the period
    the command is held for), otherwise for the reference at the tick."""
    ahead = (reference.feedforward if reference.feedforward is not None
             else (reference.position, reference.velocity, reference.acceleration))
    feedforward = feedforward_torque(config.feedforward, dynamics, *ahead)
    return pid.step(dt_s, reference.position, reference.velocity, position, velocity, feedforward)
