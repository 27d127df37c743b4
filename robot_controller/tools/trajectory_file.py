"""A joint trajectory as ``trajectory`` and ``goto`` send it, and the YAML file ``trajectory`` reads::

    joint_names: [joint1]
    points:
      - time_from_start: 1.0        # s from when the planner takes it
        positions: [0.5]            # rad, one per joint name
        velocities: [0.0]           # optional: rad/s (every point or none)
        accelerations: [0.0]        # optional: rad/s² (every point or none)

The file is checked on its own (keys, numbers, lengths, times in order); joints and limits are the planner's to check.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

TOP_KEYS = ("joint_names", "points")
POINT_KEYS = ("time_from_start", "positions", "velocities", "accelerations")
# goto's default duration: the farthest joint at this mean speed, its speed stopped at this deceleration, a minimum.
GOTO_SPEED = 0.5  # rad/s
GOTO_DECELERATION = 2.0  # rad/s²
GOTO_MIN_S = 1.0
GOTO_UNKNOWN_S = 3.0  # when the arm's state is not heard


class TrajectoryFileError(ValueError):
    """A file or request that cannot be sent: one line naming the key and the problem."""


@dataclass(frozen=True)
class Point:
    time_from_start_s: float
    positions: list[float]
    velocities: list[float] = field(default_factory=list)
    accelerations: list[float] = field(default_factory=list)


@dataclass(frozen=True)
class TrajectorySpec:
    joint_names: list[str]
    points: list[Point]

    @property
    def duration_s(self) -> float:
        return self.points[-1].time_from_start_s


def _check_keys(raw: dict, known: Sequence[str], required: Sequence[str], where: str) -> None:
    """Every key of ``raw`` known (a close one suggested), every one ``required`` there."""
    for key in raw:
        if key not in known:
            close = difflib.get_close_matches(str(key), known, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else f" (expected {', '.join(known)})"
            raise TrajectoryFileError(f"{where}{key!r}: unknown key{hint}")
    for key in required:
        if key not in raw:
            raise TrajectoryFileError(f"{where}{key}: missing")


def _is_finite_number(value: Any) -> bool:
    return not isinstance(value, bool) and isinstance(value, int | float) and math.isfinite(value)


def _numbers(value: Any, where: str, count: int) -> list[float]:
    if not isinstance(value, list):
        raise TrajectoryFileError(f"{where}: expected a list of {count} number(s), got {type(value).__name__}")
    if len(value) != count:
        raise TrajectoryFileError(f"{where}: expected {count} number(s) (one per joint name), got {len(value)}")
    numbers = []
    for k, item in enumerate(value):
        if not _is_finite_number(item):
            raise TrajectoryFileError(f"{where}[{k}]: expected a finite number, got {item!r}")
        numbers.append(float(item))
    return numbers


def _point(raw: Any, k: int, joints: int, previous_s: float | None) -> Point:
    where = f"points[{k}]"
    if not isinstance(raw, dict):
        raise TrajectoryFileError(f"{where}: expected a mapping with time_from_start and positions")
    _check_keys(raw, POINT_KEYS, ("time_from_start", "positions"), f"{where}.")
    t = raw["time_from_start"]
    if not _is_finite_number(t) or t < 0:
        raise TrajectoryFileError(f"{where}.time_from_start: expected a finite number of seconds >= 0, got {t!r}")
    if previous_s is not None and t <= previous_s:
        raise TrajectoryFileError(f"{where}.time_from_start: {t:g} s is not after points[{k - 1}]'s {previous_s:g} s")
    optional = {
        key: _numbers(raw[key], f"{where}.{key}", joints) for key in ("velocities", "accelerations") if key in raw
    }
    return Point(float(t), _numbers(raw["positions"], f"{where}.positions", joints), **optional)


def parse(document: Any) -> TrajectorySpec:
    """A loaded YAML document as a trajectory (``TrajectoryFileError`` naming the key)."""
    if not isinstance(document, dict):
        raise TrajectoryFileError("expected a mapping with joint_names and points")
    _check_keys(document, TOP_KEYS, TOP_KEYS, "")
    names = document["joint_names"]
    if not isinstance(names, list) or not names or not all(isinstance(n, str) and n for n in names):
        raise TrajectoryFileError(f"joint_names: expected a list of joint names, got {names!r}")
    raw_points = document["points"]
    if not isinstance(raw_points, list) or not raw_points:
        raise TrajectoryFileError("points: expected a list of at least one point")
    points: list[Point] = []
    for k, raw in enumerate(raw_points):
        points.append(_point(raw, k, len(names), points[-1].time_from_start_s if points else None))
    for key in ("velocities", "accelerations"):
        given = [bool(getattr(p, key)) for p in points]
        if any(given) and not all(given):
            missing = given.index(False)
            raise TrajectoryFileError(f"points[{missing}].{key}: missing (give {key} for every point or none)")
    return TrajectorySpec(list(names), points)


def load(path: Path) -> TrajectorySpec:
    """The trajectory in the YAML file at ``path`` (``TrajectoryFileError``: one line, starting with the path)."""
    text = Path(path).read_text()
    try:
        document = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark is not None else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise TrajectoryFileError(f"{path}: not YAML{where}: {problem}") from None
    try:
        return parse(document)
    except TrajectoryFileError as exc:
        raise TrajectoryFileError(f"{path}: {exc}") from None


def goto_time_s(distance_rad: float, speed_rad_s: float) -> float:
    """goto's default duration for the farthest joint ``distance_rad`` away, the fastest moving at ``speed_rad_s``."""
    return max(GOTO_MIN_S, distance_rad / GOTO_SPEED, speed_rad_s / GOTO_DECELERATION)


def goto(positions: Sequence[float], joint_names: Sequence[str], time_s: float) -> TrajectorySpec:
    """One point: ``positions`` (rad, one per name) reached at ``time_s``, at rest."""
    if len(positions) != len(joint_names):
        raise TrajectoryFileError(f"{len(positions)} position(s) for {len(joint_names)} joint(s) {list(joint_names)}")
    values = [float(q) for q in positions]
    if not all(math.isfinite(q) for q in values):
        raise TrajectoryFileError(f"positions must be finite numbers, got {values}")
    if not (math.isfinite(time_s) and time_s > 0):
        raise TrajectoryFileError(f"--time must be a finite number > 0, got {time_s}")
    return TrajectorySpec(list(joint_names), [Point(float(time_s), values)])
