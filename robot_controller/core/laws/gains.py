"""The control law: which gains are in force (the PID's own, or for LQR a
discrete Riccati design that replaces them), a one-line account of them,
their delay margin, and one step of feedback plus model feedforward (less
the disturbance observer's estimate of an external torque) within the torque
limit.

Gains: Kp N·m/rad, Ki N·m/(rad·s), Kd N·m·s/rad; torques N·m; times s.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from robot_controller.core.controller.config import ControllerConfig
from robot_controller.core.controller.reference_at_tick import Reference
from robot_controller.core.errors import ConfigError
from robot_controller.core.estimation.estimator import KalmanConfig, steady_state_gain
from robot_controller.core.laws import lqr
from robot_controller.core.laws.feedforward import FeedforwardMode, feedforward_torque
from robot_controller.core.laws.pid import DerivativeSource, Pid, PidConfig, PidTerms
from robot_controller.core.model import ArmDynamics


def law_config(
    config: ControllerConfig, dynamics: ArmDynamics | None, joint_count: int, kind: str | None = None
) -> PidConfig:
    """The PID settings the built-in law ``kind`` ("pid" or "lqr"; None: the one
    ``config`` runs, see :attr:`ControllerConfig.builtin_law`) runs with. For LQR, the gains come from a
    discrete Riccati design on each joint's ``[∫e, e, ė]`` at the control rate
    (with feedforward carrying the motion, the feedback is exactly a PID on
    velocity error with these gains)."""
    if (kind or config.builtin_law) == "pid":
        return config.pid
    if dynamics is None:
        raise ConfigError("controller_type lqr: needs the arm model (urdf_path)")
    inertia = design_inertia(dynamics, joint_count, config.design_position)
    gains = np.array(
        [
            lqr.design(
                inertia[j],
                dynamics.damping[j],
                config.control_period_s,
                np.array(config.lqr_q),
                torque_weight(config.lqr_r, config.reference_inertia, inertia[j]),
            ).K[0]
            for j in range(joint_count)
        ]
    )
    return replace(
        config.pid, ki=gains[:, 0], kp=gains[:, 1], kd=gains[:, 2], derivative_source=DerivativeSource.VELOCITY_ERROR
    )


def design_inertia(
    dynamics: ArmDynamics, joint_count: int, design_position: tuple[float, ...] | None = None
) -> np.ndarray:
    """Each joint's own inertia (the mass matrix's diagonal, kg·m²) at the design
    pose (rad per joint; None: every joint at 0, or the nearest end of its range
    where 0 is outside it). Each joint's gains are designed for it, so one set of
    weights serves a shoulder and a wrist a hundred times lighter."""
    if design_position is not None:
        pose = np.asarray(design_position, dtype=float)
    else:
        pose = np.zeros(joint_count)
        model = getattr(dynamics, "model", None)  # a MuJoCo model knows the joints' ranges
        if model is not None:
            limited = model.jnt_limited[:joint_count].astype(bool)
            low, high = model.jnt_range[:joint_count, 0], model.jnt_range[:joint_count, 1]
            pose = np.where(limited, np.clip(pose, low, high), pose)
    return np.diag(dynamics.mass_matrix(pose)).copy()


def observer_torque_scale(inertia_kgm2: np.ndarray, reference_inertia_kgm2: float) -> np.ndarray | None:
    """Per joint, the factor on the disturbance observer's torque σs: the joint's inertia over the
    reference inertia they were chosen for (None when that is 0: the σs as they are)."""
    if reference_inertia_kgm2 <= 0:
        return None
    return np.asarray(inertia_kgm2, dtype=float) / reference_inertia_kgm2


def torque_weight(lqr_r: float, reference_inertia_kgm2: float, inertia_kgm2: float) -> float:
    """A joint's LQR torque weight: ``lqr_r`` scaled so that the cost of an
    acceleration is the same on every joint (``lqr_r`` as it is for a joint of
    the reference inertia, or for every joint when that is 0). The gains then
    come out in proportion to each joint's inertia, and every joint's error
    dies away alike: with one torque weight for all, a wrist 200 times lighter
    than the shoulder would be stiffened far beyond it, the shoulder left soft."""
    if reference_inertia_kgm2 <= 0:
        return lqr_r
    return lqr_r * (reference_inertia_kgm2 / inertia_kgm2) ** 2


def _values(values: np.ndarray | tuple[float, ...]) -> str:
    return "[" + ", ".join(f"{float(v):.3g}" for v in np.atleast_1d(values)) + "]"


def describe_law(config: ControllerConfig, gains: PidConfig) -> str:
    """One line for a log or a status topic: the law, the gains in force with
    their units, the torque limit and the feedforward. In LQR mode it says so,
    and that the kp/ki/kd parameters are unused (the design replaced them)."""
    in_force = (
        f"Kp={_values(gains.kp)} N·m/rad, Ki={_values(gains.ki)} N·m/(rad·s), "
        f"Kd={_values(gains.kd)} N·m·s/rad, D on {gains.derivative_source.value}, "
        f"|torque| <= {_values(gains.output_limit)} N·m, feedforward {config.feedforward.value}"
    )
    if config.observes_disturbance:
        in_force += (
            f", disturbance observer (σ {config.estimator.disturbance_noise_std:g} N·m/√s, " "estimate subtracted)"
        )
    if config.builtin_law == "lqr":
        return (
            f"LQR (q={_values(config.lqr_q)}, r={config.lqr_r:g}, designed at "
            f"{1.0 / config.control_period_s:g} Hz): {in_force}; the kp/ki/kd parameters are unused"
        )
    return f"PID: {in_force}"


def delay_margin_periods(
    gains: PidConfig,
    dynamics: ArmDynamics | None,
    joint_count: int,
    control_period_s: float,
    estimator: KalmanConfig | None = None,
    disturbance_observer: bool = False,
    design_position: tuple[float, ...] | None = None,
    reference_inertia: float = 0.0,
) -> int | None:
    """Whole control periods of unaccounted delay the feedback with ``gains``
    survives on the worst joint, the arm linearised at rest (see
    :func:`lqr.delay_margin_periods`). None without the arm model.

    With the disturbance observer (``disturbance_observer`` and an
    ``estimator``), the loop runs through the filter: the estimate of the
    external torque is fed back too, and it is what a late reading misleads
    most (the arm lags the model, and the observer takes that for a push). The
    margin is then that of the whole loop, filter (its steady-state gains) and
    observer included: :func:`observer_delay_margin_periods`, for the filter
    as it is while the readings agree with it and as it becomes when they do
    not (late readings make them disagree: ``KalmanConfig.at_mismatch``), the
    worse of the two. (A jump is taken only among agreeing readings, so late
    readings seldom make the observer jump: twice in 6 s with 20 ms of
    unaccounted delay, a bump but no chatter.)"""
    if dynamics is None:
        return None
    inertia = design_inertia(dynamics, joint_count, design_position)
    scale = observer_torque_scale(inertia, reference_inertia)
    margins = []
    for j in range(joint_count):
        if disturbance_observer and estimator is not None:
            joint_filter = estimator if scale is None else estimator.for_inertia(float(scale[j]))
            margins.extend(
                observer_delay_margin_periods(
                    (float(gains.ki[j]), float(gains.kp[j]), float(gains.kd[j])),
                    filter_,
                    float(inertia[j]),
                    float(dynamics.damping[j]),
                    control_period_s,
                )
                for filter_ in (joint_filter, joint_filter.at_mismatch())
            )
            continue
        A, B = lqr.discretise(float(inertia[j]), float(dynamics.damping[j]), control_period_s)
        K = np.array([[gains.ki[j], gains.kp[j], gains.kd[j]]], dtype=float)
        margins.append(lqr.delay_margin_periods(A, B, K))
    return min(margins)


def observer_delay_margin_periods(
    gains: tuple[float, float, float],
    estimator: KalmanConfig,
    inertia: float,
    damping: float,
    period_s: float,
    max_periods: int = 50,
) -> int:
    """How many whole periods of unaccounted delay one joint's loop survives
    with the Kalman filter and its disturbance observer in it (``gains``:
    Ki, Kp, Kd of the PID on the filtered state; the arm ``inertia·q̈ +
    damping·q̇ = τ``, at rest).

    Each tick k: the reading is the arm's state ``delay`` periods ago, taken
    for the present (stamped on arrival); the filter predicts with the
    command it issued last and corrects with its steady-state gain
    (:func:`estimator.steady_state_gain`); the PID (integral as :class:`Pid`
    keeps it, D on the velocity error) and the estimate ``−d̂`` make the
    command, held over the period. Stable while the spectral radius of that
    linear system is below 1. Returns the largest stable delay (0: not even
    one period, or not stable at all; ``max_periods``: at least that many)."""
    ki, kp, kd = gains
    F, Bf, L = steady_state_gain(estimator, inertia, damping, period_s, estimate_disturbance=True)
    Ap, Bp = F[:2, :2], Bf[:2]
    H = np.eye(2, 3)
    for delay in range(0, max_periods + 1):
        # State: the arm now and `delay` periods back (2 each), the filter's last estimate (3),
        # the I term and the last command.
        n = 2 * (delay + 1) + 5
        est, i_term, last = slice(n - 5, n - 2), n - 2, n - 1
        predicted = np.zeros((3, n))
        predicted[:, est] = F
        predicted[:, last] += Bf[:, 0]
        reading = np.zeros((2, n))
        reading[:, 2 * delay : 2 * delay + 2] = np.eye(2)
        estimate = predicted + L @ (reading - H @ predicted)
        integral = -ki * period_s * estimate[0]
        integral[i_term] += 1.0
        command = -kp * estimate[0] - kd * estimate[1] + integral - estimate[2]
        M = np.zeros((n, n))
        M[:2] = np.hstack([Ap, np.zeros((2, n - 2))]) + Bp @ command[None, :]
        M[2 : 2 * (delay + 1), : 2 * delay] = np.eye(2 * delay)  # the arm's history moves back one period
        M[est], M[i_term], M[last] = estimate, integral, command
        if np.max(np.abs(np.linalg.eigvals(M))) >= 1.0:
            return max(delay - 1, 0)
    return max_periods


def law_step(
    pid: Pid,
    config: ControllerConfig,
    dynamics: ArmDynamics | None,
    dt_s: float,
    position: np.ndarray,
    velocity: np.ndarray,
    reference: Reference,
    disturbance: np.ndarray | None = None,
) -> PidTerms:
    """One step of the law over ``dt_s`` seconds: the model's feedforward torque
    for the reference motion plus the PID feedback on the error between the
    reference and the arm's ``position`` (rad) / ``velocity`` (rad/s), limited
    to the torque limit (and slew rate) by the PID. The feedforward is for
    ``reference.feedforward`` when it is given (the reference over the period
    the command is held for), otherwise for the reference at the tick.

    ``disturbance`` (N·m per joint, the observer's estimate of an external
    torque) is subtracted like one more feedforward term (it is part of the
    reported feedforward): the integral is left only what the estimate misses."""
    ahead = (
        reference.feedforward
        if reference.feedforward is not None
        else (reference.position, reference.velocity, reference.acceleration)
    )
    one_joint = getattr(dynamics, "one_joint", None)
    if one_joint is not None and config.feedforward is not FeedforwardMode.NONE and np.shape(ahead[0]) == (1,):
        # One joint: the same inverse dynamics and difference on floats.
        p, v, a = ahead[0].item(), ahead[1].item(), ahead[2].item()
        if config.feedforward is FeedforwardMode.GRAVITY:
            v = a = 0.0
        feedforward = one_joint.torque(p, v, a)
        if disturbance is not None:
            feedforward = feedforward - disturbance.item()
        return pid.step(dt_s, reference.position, reference.velocity, position, velocity, feedforward)
    feedforward = feedforward_torque(config.feedforward, dynamics, *ahead)
    if disturbance is not None:
        feedforward = feedforward - disturbance
    return pid.step(
        dt_s,
        reference.position,
        reference.velocity,
        position,
        velocity,
        feedforward,
        decoupling_map(config, dynamics, position),
    )


def decoupling_map(config: ControllerConfig, dynamics: ArmDynamics | None, position: np.ndarray) -> np.ndarray | None:
    """``M(q)·diag(M(q))⁻¹`` at ``position`` (None on one joint, without the arm model or when
    ``feedback_decoupling`` is off). Each joint's gains are for its own inertia, ``M_jj``: they
    ask for an acceleration ``τ_j / M_jj``. On a chain the joints' inertias couple, and a torque
    on one joint accelerates the others too; this map gives the torques that produce exactly the
    accelerations asked for (the feedback half of computed-torque control). Without it, a
    payload of 1 kg on the Panda's flange drove its joints to their torque limits."""
    if not config.feedback_decoupling or dynamics is None or np.size(position) < 2:
        return None
    mass = dynamics.mass_matrix(position)
    return mass / np.diag(mass)[None, :]
