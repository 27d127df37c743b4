"""Whether the arm can follow a trajectory inside its torque limit (:func:`check_feasibility`), and what to do
when it cannot (:func:`plan_trajectory`): slow it in time, refuse it, or run it with a warning, as the
``feasibility`` policy says; first for the torque, then for the URDF's velocity limits.

The torque a path needs is the arm model's inverse dynamics along it (``dynamics.torque(q, v, a)``), sampled
densely over what repeats or happens once: one period of a sine or square, a chirp's sweep up and back down, the
move of a step, the position of a hold. A fraction ``margin`` of the limit is kept free for the feedback law.

Slowing a path by ``k`` (``time_scaled``) divides its velocities by ``k`` and accelerations by ``k²``; gravity
stays. The smallest ``k`` that fits is found by bisection on the inverse dynamics, then checked on the scaled
trajectory; if gravity alone exceeds the usable torque, no ``k`` helps. A jump (an unshaped step, a square wave)
has no finite acceleration to check: only holding its levels is.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.model.velocity_envelope import VelocityEnvelope
from robot_controller.core.reference.trajectory import (
    Chirp,
    Hold,
    MinTimeStep,
    Sine,
    Square,
    Step,
    Trajectory,
    time_scaled,
)

POLICIES = ("scale", "refuse", "ignore")
DEFAULT_MARGIN = 0.2
# Samples over the window checked: at least this many, and this many per cycle of the fastest frequency.
MIN_SAMPLES = 1000
SAMPLES_PER_CYCLE = 100
# Bisection stops when the bracket is this narrow, relative to k.
RELATIVE_TOLERANCE = 1e-3
# Slowing by more than this is not a fix (gravity then takes nearly all of the usable torque).
MAX_SCALE = 1000.0
_FIT_EPS_NM = 1e-9


class InverseDynamics(Protocol):
    def torque(self, position: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
        """Joint torque that gives ``acceleration`` at state ``(position, velocity)``."""
        ...


@dataclass(frozen=True)
class Feasibility:
    """What a trajectory needs against what the actuator can give, per joint (N·m)."""

    peak_torque_nm: np.ndarray  #: the largest |torque| along the path as given
    limit_nm: np.ndarray
    margin: float
    gravity_nm: np.ndarray  #: the largest |torque| to hold the path's positions still: what no slowing removes
    scale: float  #: the time factor k ≥ 1 that makes the path fit (1: it fits; inf: slowing cannot)
    scaled_peak_torque_nm: np.ndarray  #: the peak once slowed by ``scale`` (the gravity peak when none fits)
    joint_names: tuple[str, ...]

    @property
    def usable_nm(self) -> np.ndarray:
        """The torque the path may use: the limit less the margin kept for feedback."""
        return self.limit_nm * (1.0 - self.margin)

    @property
    def feasible(self) -> bool:
        return bool(np.all(self.peak_torque_nm <= self.usable_nm + _FIT_EPS_NM))

    @property
    def fixable(self) -> bool:
        """Slowing the path in time makes it fit (true when it fits already)."""
        return bool(np.isfinite(self.scale))

    @property
    def worst_joint(self) -> int:
        """The joint whose need is largest against its usable torque."""
        return int(np.argmax(self.peak_torque_nm / self.usable_nm))

    def shortfall(self, what: str) -> str:
        """``the chirp needs 31.8 N·m on joint1 against 8.0 N·m usable (10.0 N·m limit, 20 % kept for feedback)``."""
        j = self.worst_joint
        return (
            f"the {what} needs {newton_metres(self.peak_torque_nm[j])} N·m on {self.joint_names[j]} against "
            f"{newton_metres(self.usable_nm[j])} N·m usable ({newton_metres(self.limit_nm[j])} N·m limit, "
            f"{self.margin * 100:.0f} % kept for feedback)"
        )

    def gravity_shortfall(self) -> str:
        """Why slowing cannot help, naming the joint where gravity alone is too much."""
        over = self.gravity_nm / self.usable_nm
        j = int(np.argmax(over))
        if over[j] <= 1.0:  # fits, but with so little to spare that no reasonable slowing gets there
            return (
                f"holding its positions alone takes {newton_metres(self.gravity_nm[j])} N·m on {self.joint_names[j]} "
                f"(gravity), so it would have to go more than {MAX_SCALE:g} times slower"
            )
        return (
            f"holding its positions alone needs {newton_metres(self.gravity_nm[j])} N·m on {self.joint_names[j]} "
            f"(gravity), which no slowing reduces"
        )


def newton_metres(value: float) -> str:
    """A torque in N·m for a message: one decimal from 1 N·m up, two below."""
    return f"{value:.1f}" if abs(value) >= 0.995 else f"{value:.2f}"


def sample_times(trajectory: Trajectory) -> np.ndarray:
    """Times (s since the trajectory started) that cover everything it does once. A chirp's window is its
    sweep up and back down: the sweep rate's acceleration term changes sign between them."""
    if isinstance(trajectory, Sine | Square):
        if trajectory.frequency_hz <= 0:
            return np.zeros(1)
        return np.linspace(0.0, 1.0 / trajectory.frequency_hz, MIN_SAMPLES, endpoint=False)
    if isinstance(trajectory, Chirp):
        window_s = 2.0 * trajectory.sweep_time_s
        cycles = window_s * max(trajectory.frequency_hz, trajectory.end_frequency_hz)
        count = max(MIN_SAMPLES, int(np.ceil(cycles * SAMPLES_PER_CYCLE)))
        return np.linspace(0.0, window_s, count, endpoint=False)
    if isinstance(trajectory, MinTimeStep):
        start = trajectory.step_time_s
        move = np.linspace(start, start + trajectory.move_time_s, MIN_SAMPLES + 1)
        return np.concatenate(([0.0], move))
    if isinstance(trajectory, Step):
        return np.array([0.0, trajectory.step_time_s])
    if isinstance(trajectory, Hold):
        return np.zeros(1)
    raise TypeError(f"no feasibility check for a {type(trajectory).__name__}")


def _scalable(trajectory: Trajectory) -> bool:
    """Slowing it changes the torque it needs (a jump, a square or a hold has no motion to slow)."""
    return isinstance(trajectory, Sine | Chirp | MinTimeStep)


def _path(trajectory: Trajectory) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    samples = [trajectory.sample(float(t)) for t in sample_times(trajectory)]
    return tuple(np.array([s[i] for s in samples]) for i in range(3))  # type: ignore[return-value]


def _peak(dynamics: InverseDynamics, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Largest |torque| per joint over the sampled states."""
    peak = np.zeros(q.shape[1])
    for qi, vi, ai in zip(q, v, a, strict=True):
        np.maximum(peak, np.abs(dynamics.torque(qi, vi, ai)), out=peak)
    return peak


def peak_torque(trajectory: Trajectory, dynamics: InverseDynamics) -> np.ndarray:
    """Largest |torque| per joint the arm needs to follow ``trajectory`` exactly, N·m."""
    return _peak(dynamics, *_path(trajectory))


def check_feasibility(
    trajectory: Trajectory,
    dynamics: InverseDynamics,
    limit_nm: float | Sequence[float] | np.ndarray,
    margin: float = DEFAULT_MARGIN,
    joint_names: Sequence[str] | None = None,
) -> Feasibility:
    """The torque ``trajectory`` needs against ``limit_nm`` (one per joint, or one for all) less ``margin``
    (0 ≤ margin < 1), and the time scale that fits. ``joint_names``: for messages (default
    ``dynamics.joint_names``, else joint1, joint2…)."""
    if not np.isfinite(margin) or not 0.0 <= margin < 1.0:
        raise ConfigError(f"feasibility_margin: must be in [0, 1), got {margin}")
    q, v, a = _path(trajectory)
    n = q.shape[1]
    limit = np.atleast_1d(np.asarray(limit_nm, dtype=float))
    if limit.size == 1:
        limit = np.full(n, float(limit[0]))
    if limit.shape != (n,) or not np.all(np.isfinite(limit)) or np.any(limit <= 0):
        raise ConfigError(f"torque_max: expected {n} finite value(s) > 0, got {limit.tolist()}")
    names = tuple(
        joint_names
        if joint_names is not None
        else getattr(dynamics, "joint_names", None) or [f"joint{i + 1}" for i in range(n)]
    )
    usable = limit * (1.0 - margin)
    zero = np.zeros_like(v)
    peak = _peak(dynamics, q, v, a)
    gravity = _peak(dynamics, q, zero, zero)

    def fits(peak_nm: np.ndarray) -> bool:
        return bool(np.all(peak_nm <= usable + _FIT_EPS_NM))

    def result(scale: float, scaled_peak: np.ndarray) -> Feasibility:
        return Feasibility(peak, limit, float(margin), gravity, scale, scaled_peak, names)

    if fits(peak):
        return result(1.0, peak)
    if not _scalable(trajectory) or not fits(gravity):
        return result(float("inf"), gravity)

    def scaled_peak(k: float) -> np.ndarray:  # the same states passed through k times slower
        return _peak(dynamics, q, v / k, a / (k * k))

    low, high = 1.0, 2.0
    while not fits(scaled_peak(high)):
        low, high = high, 2.0 * high
        if high > MAX_SCALE:
            return result(float("inf"), gravity)
    while high - low > RELATIVE_TOLERANCE * high:
        middle = 0.5 * (low + high)
        if fits(scaled_peak(middle)):
            high = middle
        else:
            low = middle
    # Checked on the trajectory slowed as it will run: a shaped step's half-moves are whole planner
    # periods, so its acceleration falls in steps rather than as 1/k², and k grows until it fits.
    while high <= MAX_SCALE:
        final = peak_torque(time_scaled(trajectory, high), dynamics)
        if fits(final):
            return result(high, final)
        high *= 1.0 + max(RELATIVE_TOLERANCE, 0.01)
    return result(float("inf"), gravity)


@dataclass(frozen=True)
class Plan:
    """The trajectory to run, the check behind it and the line to warn with (None when it fits)."""

    trajectory: Trajectory
    result: Feasibility
    warning: str | None = None


def describe_scaling(original: Trajectory, scaled: Trajectory) -> str:
    """What slowing changed, in the parameters' own terms: ``frequencies 0.5→0.31 Hz …``."""
    if isinstance(original, Chirp) and isinstance(scaled, Chirp):
        return (
            f"frequencies {original.frequency_hz:.3g}→{scaled.frequency_hz:.3g} Hz to "
            f"{original.end_frequency_hz:.3g}→{scaled.end_frequency_hz:.3g} Hz, "
            f"sweep {original.sweep_time_s:.3g}→{scaled.sweep_time_s:.3g} s"
        )
    if isinstance(original, Sine | Square) and isinstance(scaled, Sine | Square):
        return f"frequency {original.frequency_hz:.3g}→{scaled.frequency_hz:.3g} Hz"
    if isinstance(original, MinTimeStep) and isinstance(scaled, MinTimeStep):
        return (
            f"max_acceleration {original.max_acceleration:.3g}→{scaled.max_acceleration:.3g} rad/s² "
            f"(move {original.move_time_s:.3g}→{scaled.move_time_s:.3g} s)"
        )
    return "unchanged"


def plan_trajectory(
    trajectory: Trajectory,
    dynamics: InverseDynamics,
    limit_nm: float | Sequence[float] | np.ndarray,
    *,
    margin: float = DEFAULT_MARGIN,
    policy: str = "scale",
    what: str = "trajectory",
    joint_names: Sequence[str] | None = None,
    velocity_limit: np.ndarray | None = None,
    position_range: tuple[np.ndarray, np.ndarray] | None = None,
    envelope: VelocityEnvelope | None = None,
) -> Plan:
    """Check ``trajectory`` against each joint's ``position_range`` (lower, upper; leaving it is refused under
    every policy), the torque, and each joint's ``velocity_limit`` (rad/s), and act as ``policy`` says: ``scale``
    slows a path that does not fit until it does, ``refuse`` refuses it, ``ignore`` runs it with a warning. A
    path no slowing makes fit (gravity alone is too much) is refused under ``scale`` and ``refuse``. ``what``
    names the path in the messages (the planner's ``mode``); a refusal is a one-line ``ConfigError``. ``envelope``:
    the robot's speed limits near its position limits (a robot's own), within the same share of them as of
    ``velocity_limit`` where both are given."""
    if position_range is not None:
        _within_range(trajectory, *position_range, what, joint_names)
    torque_plan = _torque_plan(trajectory, dynamics, limit_nm, margin, policy, what, joint_names)
    if velocity_limit is None:
        return torque_plan
    return _within_velocity_limits(torque_plan, np.asarray(velocity_limit, float), policy, what, joint_names, envelope)


def _within_range(
    trajectory: Trajectory, lower: np.ndarray, upper: np.ndarray, what: str, joint_names: Sequence[str] | None
) -> None:
    """Refuse a path that leaves a joint's position range (slowing it moves no position)."""
    q = _path(trajectory)[0]
    low, high = q.min(axis=0), q.max(axis=0)
    outside = np.flatnonzero((low < lower - 1e-9) | (high > upper + 1e-9))
    if outside.size:
        j = int(outside[0])
        name = joint_names[j] if joint_names is not None else f"joint{j + 1}"
        raise ConfigError(
            f"the {what} reaches [{low[j]:.4g}, {high[j]:.4g}] rad on {name}, beyond its limits "
            f"[{lower[j]:g}, {upper[j]:g}] rad: lower the amplitude or move the offset"
        )


def _within_velocity_limits(
    planned: Plan,
    velocity_limit: np.ndarray,
    policy: str,
    what: str,
    joint_names: Sequence[str] | None,
    envelope: VelocityEnvelope | None = None,
) -> Plan:
    """The plan slowed further, refused or run with a warning when its path goes faster than a joint's URDF
    velocity limit (or, with an ``envelope``, than the robot allows where the joint is)."""

    def fastest(trajectory: Trajectory) -> tuple[int, float, float, float]:
        """The joint furthest over its limit: its index, its ratio to the limit, its speed and the limit there."""
        q, v, _ = _path(trajectory)
        limit = np.broadcast_to(velocity_limit, v.shape)
        if envelope is not None:  # as far inside the envelope as inside the top speed
            limit = np.minimum(limit, velocity_limit / envelope.max_rad_s * envelope.limit(q, v))
        speed = np.abs(v)
        with np.errstate(divide="ignore", invalid="ignore"):
            ratios = np.where(speed > 1e-9, speed / limit, 0.0)
        k, j = np.unravel_index(int(np.argmax(ratios)), ratios.shape)
        return int(j), float(ratios[k, j]), float(speed[k, j]), float(limit[k, j])

    j, ratio, speed, limit = fastest(planned.trajectory)
    if ratio <= 1.0 + 1e-9:
        return planned
    name = joint_names[j] if joint_names is not None else f"joint {j + 1}"
    where = "its URDF velocity limit" if envelope is None else "the speed the robot allows it there"
    need = f"the {what} moves {name} at {speed:.3g} rad/s, beyond {where} {limit:.3g} rad/s"
    earlier = "" if planned.warning is None else planned.warning + "; "
    if policy == "ignore":
        return Plan(planned.trajectory, planned.result, f"{earlier}{need}; running it as it is (feasibility: ignore)")
    if policy == "refuse" or not _scalable(planned.trajectory) or not np.isfinite(ratio):
        raise ConfigError(f"{need}; slow it down or lower the amplitude")
    factor = ratio
    while factor <= MAX_SCALE:
        scaled = time_scaled(planned.trajectory, factor)
        if fastest(scaled)[1] <= 1.0 + 1e-9:
            return Plan(
                scaled,
                planned.result,
                f"{earlier}{need}: scaled in time ×{factor:.2f}: {describe_scaling(planned.trajectory, scaled)}",
            )
        factor *= 1.01
    raise ConfigError(f"{need}; slow it down or lower the amplitude")


def _torque_plan(
    trajectory: Trajectory,
    dynamics: InverseDynamics,
    limit_nm: float | Sequence[float] | np.ndarray,
    margin: float,
    policy: str,
    what: str,
    joint_names: Sequence[str] | None,
) -> Plan:
    """:func:`plan_trajectory` on the torque alone."""
    if policy not in POLICIES:
        raise ConfigError(f"feasibility: {policy!r} is not one of {list(POLICIES)}")
    result = check_feasibility(trajectory, dynamics, limit_nm, margin, joint_names)
    if result.feasible:
        return Plan(trajectory, result)
    need = result.shortfall(what)
    if policy == "ignore":
        cannot = "" if result.fixable else f"; {result.gravity_shortfall()}"
        return Plan(
            trajectory,
            result,
            f"{need}{cannot}; running it as it is (feasibility: ignore): "
            "expect the torque to saturate and the arm to lag",
        )
    if not result.fixable:
        raise ConfigError(f"{need}; {result.gravity_shortfall()}: lower the amplitude or offset, or raise torque_max")
    if policy == "refuse":
        raise ConfigError(f"{need}; slow it down (feasibility: scale) or lower the amplitude")
    scaled = time_scaled(trajectory, result.scale)
    j = result.worst_joint
    return Plan(
        scaled,
        result,
        f"{need}: scaled in time ×{result.scale:.2f}: {describe_scaling(trajectory, scaled)}; "
        f"it now needs {newton_metres(result.scaled_peak_torque_nm[j])} N·m",
    )
