"""What to do with a trajectory the arm cannot follow (:func:`plan_trajectory`): slow it in
time, refuse it, or run it with a warning, as the ``feasibility`` policy says; first for the torque
(:func:`~robot_controller.core.reference.feasibility_check.check_feasibility`), then for the
URDF's velocity limits."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.reference.feasibility_check import (
    DEFAULT_MARGIN,
    MAX_SCALE,
    POLICIES,
    Feasibility,
    InverseDynamics,
    _move_time_s,
    _nm,
    _path,
    _scalable,
    check_feasibility,
)
from robot_controller.core.reference.trajectory import Chirp, MinTimeStep, Sine, Square, Trajectory, time_scaled


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
            f"(move {_move_time_s(original):.3g}→{_move_time_s(scaled):.3g} s)"
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
) -> Plan:
    """Check ``trajectory`` (each joint's ``position_range``, lower and upper, if given: a path
    leaving it is refused under every policy; torque; each joint's ``velocity_limit``, rad/s,
    if given) and act on the result as ``policy`` says.

    ``scale``: a path that does not fit is slowed in time until it does (the
    warning names the numbers and the factor). ``refuse``: it is refused.
    ``ignore``: it runs as it is, with a warning. A path that no slowing makes
    fit (gravity alone is too much) is refused under ``scale`` and ``refuse``.

    :param what: how the messages name the path (the planner's ``mode``)
    :raises ConfigError: one line with the numbers, when the path is refused
    """
    if position_range is not None:
        _within_range(trajectory, *position_range, what, joint_names)
    torque_plan = _torque_plan(trajectory, dynamics, limit_nm, margin, policy, what, joint_names)
    if velocity_limit is None:
        return torque_plan
    return _within_velocity_limits(torque_plan, np.asarray(velocity_limit, float), policy, what, joint_names)


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
    planned: Plan, velocity_limit: np.ndarray, policy: str, what: str, joint_names: Sequence[str] | None
) -> Plan:
    """The plan slowed further (``scale``), refused or run with a warning when its
    path goes faster than a joint's URDF velocity limit (naming the joint)."""

    def fastest(trajectory: Trajectory) -> tuple[np.ndarray, int, float]:
        speed = np.max(np.abs(_path(trajectory)[1]), axis=0)
        ratio = speed / velocity_limit
        worst = int(np.argmax(ratio))
        return speed, worst, float(ratio[worst])

    speed, j, ratio = fastest(planned.trajectory)
    if ratio <= 1.0 + 1e-9:
        return planned
    name = joint_names[j] if joint_names is not None else f"joint {j + 1}"
    need = (
        f"the {what} moves {name} at {speed[j]:.3g} rad/s, beyond its URDF velocity limit "
        f"{velocity_limit[j]:.3g} rad/s"
    )
    earlier = "" if planned.warning is None else planned.warning + "; "
    if policy == "ignore":
        return Plan(planned.trajectory, planned.result, f"{earlier}{need}; running it as it is (feasibility: ignore)")
    if policy == "refuse" or not _scalable(planned.trajectory):
        raise ConfigError(f"{need}; slow it down or lower the amplitude")
    factor = ratio
    while factor <= MAX_SCALE:
        scaled = time_scaled(planned.trajectory, factor)
        if fastest(scaled)[2] <= 1.0 + 1e-9:
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
        raise ConfigError(
            f"{need}; {result.gravity_shortfall()}: lower the amplitude or offset, " "or raise torque_max"
        )
    if policy == "refuse":
        raise ConfigError(f"{need}; slow it down (feasibility: scale) or lower the amplitude")
    scaled = time_scaled(trajectory, result.scale)
    j = result.worst_joint
    return Plan(
        scaled,
        result,
        f"{need}: scaled in time ×{result.scale:.2f}: {describe_scaling(trajectory, scaled)}; "
        f"it now needs {_nm(result.scaled_peak_torque_nm[j])} N·m",
    )
