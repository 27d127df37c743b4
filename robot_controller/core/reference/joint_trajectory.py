"""Joint trajectories as ros2_controllers' JointTrajectoryController takes them: checked, then joined smoothly
onto the reference in force.

:func:`check_waypoints` turns a ``trajectory_msgs/JointTrajectory`` (the arm's joint names in any order; points with
strictly increasing times, positions, and optionally velocities and accelerations) into arrays in the arm's order,
or a one-line reason. :func:`blend` starts at the reference in force (position, velocity and acceleration, so
nothing jumps), runs a :class:`QuinticPath` through the points and holds the last; a first point at time 0 is the
current state and must be within ``START_TOLERANCE_RAD`` of the reference. :func:`accept_joint_trajectory` does
both, then checks the path between the points: the quintics may swing past a limit the points are within, so the
path is sampled (``LIMIT_PER_SEGMENT`` per segment) against each joint's position and velocity limits, and the
torque the arm model needs along it (at most ``TORQUE_SAMPLES`` inverse-dynamics calls, in the planner's executor)
against the limit less the feedback margin. Nothing is slowed: a user's timing is theirs.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from robot_controller.core.model import JointLimits
from robot_controller.core.reference.feasibility import newton_metres
from robot_controller.core.reference.quintic_path import QuinticPath, knot_accelerations, knot_velocities
from robot_controller.core.reference.stop import overshoots, rest_position, stop_time_s
from robot_controller.core.reference.trajectory import Sample

# A first point at time 0 must be this close to the reference in force (MoveIt's
# allowed_start_tolerance): it is taken as "where the arm is", not as a jump.
START_TOLERANCE_RAD = 0.01
# The last point's velocity and acceleration must be 0 to within this.
AT_REST_TOLERANCE = 1e-6
# Each point costs the check time in the planner's executor (inverse dynamics along the path).
MAX_POINTS = 500
LIMIT_PER_SEGMENT = 256
TORQUE_SAMPLES = 2000
MIN_PER_SEGMENT = 4
MAX_PER_SEGMENT = 64
_EPS = 1e-9

Values = Sequence[Sequence[float]]


@dataclass(frozen=True)
class Waypoints:
    """A checked trajectory in the arm's joint order (``joint_names``): ``(N,)`` times (s
    from its start), ``(N, joints)`` positions, and velocities and accelerations or None
    where not given."""

    joint_names: tuple[str, ...]
    times_s: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray | None
    accelerations: np.ndarray | None


@dataclass(frozen=True)
class JointTrajectory:
    """The motion: the blend from the reference in force, then through the points, then
    held. Time 0 is when it was taken; the points are ``start_delay_s`` later than their
    ``time_from_start``. Implements ``Trajectory``."""

    path: QuinticPath
    waypoints: Waypoints
    start_delay_s: float
    stop_first_s: float = 0.0  #: the reference came to rest first (``blend``), so the points are this much later

    def sample(self, t: float) -> Sample:
        return self.path.sample(t)

    @property
    def duration_s(self) -> float:
        return self.path.duration_s

    @property
    def final_position(self) -> np.ndarray:
        return self.path.final_position


@dataclass(frozen=True)
class Accepted:
    """A trajectory that passed every check, its peak torque per joint (N·m) and, under
    ``torque_policy="warn"``, the shortfall it runs with (None if it fits)."""

    trajectory: JointTrajectory
    peak_torque_nm: np.ndarray
    warning: str | None = None


def _field(name: str, rows: Values, joints: int, points: int) -> np.ndarray | None | str:
    """One per-point field as an ``(N, joints)`` array, None if no point gives it, or a reason."""
    given = [k for k, row in enumerate(rows) if len(row) > 0]
    if not given:
        return None
    if len(given) != points:
        missing = next(k for k in range(points) if k not in given)
        return f"points[{missing}] has no {name} but other points do (give them for every point or none)"
    for k, row in enumerate(rows):
        if len(row) != joints:
            return f"points[{k}]: {len(row)} {name} for {joints} joint(s)"
    return np.array(rows, dtype=float).reshape(points, joints)


def joint_names_problem(names: Sequence[str], arm: Sequence[str], allow_partial: bool = False) -> str | None:
    """Why a trajectory's joint names cannot drive the arm (``arm``: its joints), or None: each named once, each the
    arm's, and every joint of the arm unless ``allow_partial`` (the others then hold where their reference is)."""
    repeated = sorted(name for name, count in Counter(names).items() if count > 1)
    if repeated:
        return f"joint {repeated[0]!r} is named more than once"
    unknown = [name for name in names if name not in arm]
    if unknown:
        return f"unknown joint(s) {unknown}: the arm's joints are {list(arm)}"
    missing = [name for name in arm if name not in names]
    if missing and not allow_partial:
        return f"missing joint(s) {missing}: a trajectory gives every joint of the arm {list(arm)}"
    if not names:
        return "no joint names"
    return None


def complete_joints(
    names: Sequence[str],
    arm: Sequence[str],
    hold: np.ndarray,
    positions: Values,
    velocities: Values,
    accelerations: Values,
) -> tuple[list[str], list[list[float]], list[list[float]], list[list[float]]]:
    """A partial trajectory's points with the arm's other joints added, each held at ``hold`` (the arm's order), at
    rest where velocities or accelerations are given."""
    others = [j for j, name in enumerate(arm) if name not in names]

    def widen(rows: Values, values: list[float]) -> list[list[float]]:
        return [list(row) + values if len(row) else [] for row in rows]

    held = [float(hold[j]) for j in others]
    rest = [0.0] * len(others)
    return (
        [*names, *(arm[j] for j in others)],
        widen(positions, held),
        widen(velocities, rest),
        widen(accelerations, rest),
    )


def check_waypoints(
    joint_names: Sequence[str],
    times_s: Sequence[float],
    positions: Values,
    velocities: Values,
    accelerations: Values,
    limits: JointLimits,
) -> Waypoints | str:
    """The points of a trajectory checked against the arm and reordered to its joints,
    or a one-line reason. ``velocities`` and ``accelerations`` hold one (possibly empty)
    row per point, as the message does."""
    arm = list(limits.joint_names)
    names = list(joint_names)
    reason = joint_names_problem(names, arm)
    if reason is not None:
        return reason
    points = len(times_s)
    if points == 0:
        return "no points"
    if points > MAX_POINTS:
        return f"{points} points, more than the {MAX_POINTS} taken"
    if not len(positions) == len(velocities) == len(accelerations) == points:
        return "the points' fields differ in number"
    times = np.asarray(times_s, dtype=float)
    for k, t in enumerate(times):
        if not np.isfinite(t):
            return f"points[{k}]: time_from_start is not finite"
        if k == 0 and t < 0:
            return f"points[0]: time_from_start {t:g} s is negative"
        if k > 0 and t <= times[k - 1]:
            return f"points[{k}]: time_from_start {t:g} s is not after points[{k - 1}]'s {times[k - 1]:g} s"
    n = len(arm)
    fields = {}
    for name, rows in (("positions", positions), ("velocities", velocities), ("accelerations", accelerations)):
        value = _field(name, rows, n, points)
        if name == "positions" and value is None:
            return "points[0] has no positions"
        if isinstance(value, str):
            return value
        if value is not None:
            bad = np.argwhere(~np.isfinite(value))
            if bad.size:
                k, j = bad[0]
                return f"points[{k}]: {name} of {names[j]} is not finite"
            value = value[:, [names.index(joint) for joint in arm]]  # the arm's order
        fields[name] = value
    p, v, a = fields["positions"], fields["velocities"], fields["accelerations"]
    reason = points_outside_limits(p, v, limits)
    if reason is not None:
        return reason
    last = points - 1
    for name, value, unit in (("velocity", v, "rad/s"), ("acceleration", a, "rad/s²")):
        if value is not None and np.any(np.abs(value[last]) > AT_REST_TOLERANCE):
            j = int(np.argmax(np.abs(value[last])))
            return (
                f"points[{last}] (the last): {arm[j]} {name} {value[last, j]:g} {unit} must be 0 "
                "(the arm holds the last point)"
            )
    return Waypoints(tuple(arm), times, p, v, a)


def blend(
    waypoints: Waypoints, start: Sample, start_delay_s: float = 0.0, stop_deceleration: float | None = None
) -> JointTrajectory | str:
    """The motion from ``start`` (the reference in force: position, velocity, acceleration)
    through the points, the first reached ``start_delay_s + times_s[0]`` from now; or why not.
    ``stop_deceleration`` (rad/s²): if joining the first point directly would swing past it (``stop.overshoots``),
    the reference first comes to rest within it, and the points are reached that much later."""
    p0, v0, a0 = (np.asarray(x, dtype=float) for x in start)
    times = start_delay_s + waypoints.times_s
    p, v, a = waypoints.positions, waypoints.velocities, waypoints.accelerations
    if times[0] <= 0.0:  # the first point is now: it must be where the reference is, and is taken as it
        off = np.abs(p[0] - p0)
        j = int(np.argmax(off))
        if off[j] > START_TOLERANCE_RAD:
            return (
                f"points[0] is at time 0 but {off[j]:.3g} rad from the reference in force on "
                f"{waypoints.joint_names[j]} "
                f"(more than {START_TOLERANCE_RAD:g}): give it a time_from_start > 0"
            )
        times, p = times[1:], p[1:]
        v = None if v is None else v[1:]
        a = None if a is None else a[1:]
        if len(times) == 0 and (np.any(np.abs(v0) > AT_REST_TOLERANCE) or np.any(np.abs(a0) > AT_REST_TOLERANCE)):
            return "its only point is at time 0 while the reference moves: give it a time_from_start > 0"
    path = _through((p0, v0, a0), times, p, v, a)
    if stop_deceleration is None or len(times) == 0 or not overshoots(path, (p0, v0, a0), stop_deceleration):
        return JointTrajectory(path, waypoints, float(start_delay_s))
    stop_s = stop_time_s(v0, a0, stop_deceleration)
    rest = np.zeros_like(p0)
    then = _through((rest_position((p0, v0, a0), stop_s), rest, rest), times, p, v, a)
    knots = (
        np.concatenate(([0.0], stop_s + then.times_s)),
        *(np.vstack((first, knot)) for first, knot in zip((p0, v0, a0), _knots(then), strict=True)),
    )
    return JointTrajectory(QuinticPath.through(*knots), waypoints, float(start_delay_s), stop_first_s=stop_s)


def _through(start: Sample, times, p, v, a) -> QuinticPath:
    """The path from ``start`` at 0 through the points at ``times`` (velocities, accelerations chosen if None)."""
    p0, v0, a0 = start
    knot_times = np.concatenate(([0.0], times))
    knot_p = np.vstack((p0, p))
    knot_v = knot_velocities(knot_times, knot_p, v0) if v is None else np.vstack((v0, v))
    knot_a = knot_accelerations(knot_times, knot_v, a0) if a is None else np.vstack((a0, a))
    return QuinticPath.through(knot_times, knot_p, knot_v, knot_a)


def _knots(path: QuinticPath) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The positions, velocities and accelerations at ``path``'s knots."""
    return path.sample_many(path.times_s)


def points_outside_limits(p: np.ndarray, v: np.ndarray | None, limits: JointLimits) -> str | None:
    """The first point with a position outside its joint's range or a velocity (``v``, if
    given) beyond its limit, in one line (None if every point is within them)."""
    for k, row in enumerate(p):
        for j, name in enumerate(limits.joint_names):
            if row[j] < limits.lower[j] - _EPS:
                return f"points[{k}]: {name} position {row[j]:g} rad is below its lower limit {limits.lower[j]:g} rad"
            if row[j] > limits.upper[j] + _EPS:
                return f"points[{k}]: {name} position {row[j]:g} rad is above its upper limit {limits.upper[j]:g} rad"
            if v is not None and abs(v[k, j]) > limits.velocity[j] + _EPS:
                return (
                    f"points[{k}]: {name} velocity {v[k, j]:g} rad/s is beyond its limit "
                    f"±{limits.velocity[j]:g} rad/s"
                )
    return None


def path_outside_limits(path: QuinticPath, limits: JointLimits) -> str | None:
    """Where the path goes furthest outside a joint's position range, or beyond its
    velocity limit, in one line (None if it never does)."""
    t = path.sample_times(LIMIT_PER_SEGMENT)
    p, v, _ = path.sample_many(t)
    checks = (
        (limits.lower - p, p, "rad, below its lower limit ", limits.lower, "rad"),
        (p - limits.upper, p, "rad, above its upper limit ", limits.upper, "rad"),
        (np.abs(v) - limits.velocity, v, "rad/s, beyond its velocity limit ±", limits.velocity, "rad/s"),
    )
    for excess, value, what, limit, unit in checks:
        if np.any(excess > _EPS):
            k, j = np.unravel_index(np.argmax(excess), excess.shape)  # where it is furthest out
            return (
                f"the path between the points reaches {value[k, j]:.4g} {what}{limit[j]:g} {unit} on "
                f"{limits.joint_names[j]} {t[k]:.2f} s in: add points or give them more time"
            )
    return None


def torque_shortfall(
    path: QuinticPath,
    dynamics,
    torque_limit_nm: np.ndarray,
    margin: float,
    joint_names: Sequence[str],
) -> tuple[np.ndarray, str | None]:
    """The largest |torque| per joint the arm model needs along the path (N·m), and, if
    it exceeds ``(1 - margin)`` of ``torque_limit_nm`` on some joint, a line naming
    the worst one with the numbers."""
    segments = max(1, len(path.times_s) - 1)
    per_segment = int(np.clip(TORQUE_SAMPLES // segments, MIN_PER_SEGMENT, MAX_PER_SEGMENT))
    t = path.sample_times(per_segment)
    q, v, a = path.sample_many(t)
    peak = np.zeros(q.shape[1])
    when = np.zeros(q.shape[1])
    for k in range(len(t)):
        torque = np.abs(dynamics.torque(q[k], v[k], a[k]))
        higher = torque > peak
        peak = np.where(higher, torque, peak)
        when = np.where(higher, t[k], when)
    limit = np.broadcast_to(np.asarray(torque_limit_nm, dtype=float), peak.shape)
    usable = limit * (1.0 - margin)
    if np.all(peak <= usable + _EPS):
        return peak, None
    j = int(np.argmax(peak / usable))
    return peak, (
        f"the trajectory needs {newton_metres(peak[j])} N·m on {joint_names[j]} ({when[j]:.2f} s in) against "
        f"{newton_metres(usable[j])} N·m usable ({newton_metres(limit[j])} N·m limit, "
        f"{margin * 100:.0f} % kept for feedback)"
    )


def accept_joint_trajectory(
    joint_names: Sequence[str],
    times_s: Sequence[float],
    positions: Values,
    velocities: Values,
    accelerations: Values,
    *,
    start: Sample,
    limits: JointLimits,
    dynamics,
    torque_limit_nm: np.ndarray,
    margin: float,
    start_delay_s: float = 0.0,
    torque_policy: str = "refuse",
    stop_deceleration: float | None = None,
) -> Accepted | str:
    """Check a trajectory, blend it from ``start`` and check the motion on the arm model ``dynamics`` against
    ``(1 - margin)`` of ``torque_limit_nm`` (``torque_policy``: ``refuse`` a path that needs more, or ``warn``):
    an :class:`Accepted`, or a one-line reason."""
    waypoints = check_waypoints(joint_names, times_s, positions, velocities, accelerations, limits)
    if isinstance(waypoints, str):
        return waypoints
    trajectory = blend(waypoints, start, start_delay_s, stop_deceleration)
    if isinstance(trajectory, str):
        return trajectory
    reason = path_outside_limits(trajectory.path, limits)
    if reason is not None:
        return reason
    peak, shortfall = torque_shortfall(trajectory.path, dynamics, torque_limit_nm, margin, limits.joint_names)
    if shortfall is not None and torque_policy != "warn":
        return f"{shortfall}: give its points more time"
    return Accepted(trajectory, peak, shortfall)


# A start this far ahead is a stamp on another clock (wall time sent to a planner on sim time), not a plan.
MAX_START_DELAY_S = 60.0


def start_delay(stamp_s: float, now_s: float) -> float | str:
    """How long after ``now_s`` the trajectory's time 0 is, as JTC reads ``header.stamp``:
    at the stamp if it is set (non-zero) and not in the past, else now (0); or why not."""
    if stamp_s == 0.0 or stamp_s <= now_s:
        return 0.0
    delay = stamp_s - now_s
    if delay > MAX_START_DELAY_S:
        return (
            f"header.stamp is {delay:.4g} s ahead of the planner's clock (at most {MAX_START_DELAY_S:g}): "
            "leave it 0 to start on receipt"
        )
    return delay
