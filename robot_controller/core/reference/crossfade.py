"""A live change of the planner's motion, blended (:class:`Crossfade`): ``(1 − w)·old + w·new``, ``w``
a quintic from 0 to 1 with zero slope and curvature at both ends, so position, velocity and
acceleration stay continuous, and a joint within its range on both motions stays within it.
:func:`crossfade` lengthens the blend until the torque and speed it asks for fit."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from robot_controller.core.reference.feasibility import InverseDynamics
from robot_controller.core.reference.trajectory import Sample

Motion = Callable[[float], Sample]  #: ``(position, velocity, acceleration)`` at a time on the planner's clock, s
MIN_CROSSFADE_S = 0.5
MAX_CROSSFADE_S = 30.0


@dataclass(frozen=True)
class Crossfade:
    """From motion ``old`` to motion ``new`` over ``duration_s`` from ``start_s`` (s, the planner's clock)."""

    old: Motion
    new: Motion
    start_s: float
    duration_s: float

    def at(self, time_s: float) -> Sample:
        T = self.duration_s
        s = min(max((time_s - self.start_s) / T, 0.0), 1.0)
        w = s**3 * (10 - 15 * s + 6 * s * s)
        dw = 30 * s * s * (1 - s) ** 2 / T
        ddw = 60 * s * (1 - s) * (1 - 2 * s) / T**2
        po, vo, ao = self.old(time_s)
        pn, vn, an = self.new(time_s)
        dp, dv = pn - po, vn - vo
        return po + w * dp, vo + w * dv + dw * dp, ao + w * (an - ao) + 2 * dw * dv + ddw * dp

    def done(self, time_s: float) -> bool:
        return time_s >= self.start_s + self.duration_s


def crossfade(
    old: Motion,
    new: Motion,
    start_s: float,
    dynamics: InverseDynamics,
    usable_nm,
    velocity_limit,
    speed_at: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> Crossfade:
    """The shortest blend (from ``MIN_CROSSFADE_S``, ×1.25, at most ``MAX_CROSSFADE_S``) whose sampled torque and
    speed stay within ``usable_nm`` and ``velocity_limit`` (arrays; or the two motions' own peaks, if higher), and,
    given ``speed_at`` (position, velocity → the speed each joint may have there, a robot's envelope), within it
    everywhere: the blend goes where neither motion does."""

    def sampled(at: Motion, duration_s: float) -> list:
        return [at(start_s + t) for t in np.linspace(0.0, duration_s, 50)]

    def peaks(samples: list) -> tuple[np.ndarray, np.ndarray]:
        torque = np.max([np.abs(dynamics.torque(*sample)) for sample in samples], axis=0)
        return torque, np.max([np.abs(sample[1]) for sample in samples], axis=0)

    duration = MIN_CROSSFADE_S
    while True:
        blend = Crossfade(old, new, start_s, duration)
        samples = sampled(blend.at, duration)
        (torque, speed), before, after = peaks(samples), peaks(sampled(old, duration)), peaks(sampled(new, duration))
        fits = torque <= np.maximum.reduce([usable_nm, before[0], after[0]]) + 1e-9
        fits &= speed <= np.maximum.reduce([velocity_limit, before[1], after[1]]) + 1e-9
        if speed_at is not None:
            fits &= np.all([np.abs(v) <= speed_at(q, v) + 1e-9 for q, v, _ in samples], axis=0)
        if np.all(fits) or duration * 1.25 > MAX_CROSSFADE_S:
            return blend
        duration *= 1.25
