"""Reference trajectories: position, velocity and acceleration at time ``t``.

Every trajectory is a pure function of ``t`` (s since the trajectory
started) and returns three arrays of shape ``(n,)``: rad, rad/s, rad/s².
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import Protocol

import numpy as np

from robot_controller.core.errors import ConfigError

Sample = tuple[np.ndarray, np.ndarray, np.ndarray]

MODES = ("sine", "step", "square", "chirp", "hold")
#: s: a time this close to a step's instant (its start, a shaped step's switch or end) is at it. Two clocks reach one
#: sample instant through different float sums (the graph's from nanosecond stamps, ``0.59 + 0.01``; the in-process
#: loop's ``k·period``), an ulp either side; a nanosecond is the ROS clock's resolution, a million ulps wide.
INSTANT_S = 1e-9


class Trajectory(Protocol):
    def sample(self, t: float) -> Sample:
        """Reference ``(position, velocity, acceleration)`` at ``t`` seconds."""
        ...


@dataclass(frozen=True)
class Sine:
    """``offset + amplitude·sin(2π f t)``."""

    amplitude: np.ndarray
    frequency_hz: float
    offset: np.ndarray

    def sample(self, t: float) -> Sample:
        w = 2.0 * np.pi * self.frequency_hz
        s, c = np.sin(w * t), np.cos(w * t)
        velocity_scale, acceleration_scale = self._scales
        return self.offset + self.amplitude * s, velocity_scale * c, acceleration_scale * s

    @cached_property
    def _scales(self) -> tuple[np.ndarray, np.ndarray]:
        """``amplitude·w`` and ``−amplitude·w·w``, as :meth:`sample` multiplies them out (made once)."""
        w = 2.0 * np.pi * self.frequency_hz
        return self.amplitude * w, -self.amplitude * w * w


@dataclass(frozen=True)
class Step:
    """``offset`` until ``step_time_s``, then ``offset + amplitude`` (zero velocity throughout)."""

    amplitude: np.ndarray
    step_time_s: float
    offset: np.ndarray

    def sample(self, t: float) -> Sample:
        zero = np.zeros_like(self.offset)
        position = self.offset + (self.amplitude if t >= self.step_time_s - INSTANT_S else zero)
        return position, zero, zero.copy()


@dataclass(frozen=True)
class MinTimeStep:
    """A step shaped into the fastest move within an acceleration limit (bang-bang), so the arm can follow it
    inside its torque limit and stop without overshoot. Each half lasts ``sqrt(|amplitude| / max_acceleration)``
    rounded up to whole ``grid_s``, so the acceleration switches on a sample instant and is constant over every
    sample period (a torque held over a period then matches it exactly): sampled at a switch (within
    :data:`INSTANT_S`), it gives the acceleration of the period that follows."""

    amplitude: np.ndarray
    step_time_s: float
    offset: np.ndarray
    max_acceleration: float
    grid_s: float = 0.0

    @cached_property
    def half_s(self) -> np.ndarray:
        """Per joint, how long each half of its move takes, s."""
        half = np.sqrt(np.abs(self.amplitude) / self.max_acceleration)
        if self.grid_s > 0:
            half = np.ceil(half / self.grid_s - 1e-9) * self.grid_s
        return half

    @property
    def move_time_s(self) -> float:
        """How long the slowest joint's move takes, s."""
        return float(2.0 * np.max(self.half_s))

    def sample(self, t: float) -> Sample:
        distance = np.abs(self.amplitude)
        direction = np.sign(self.amplitude)
        half = self.half_s
        a = np.divide(distance, half * half, out=np.zeros_like(distance), where=half > 0)
        tau = t - self.step_time_s
        if tau < -INSTANT_S:
            zero = np.zeros_like(self.offset)
            return self.offset.copy(), zero, zero.copy()
        tau = max(tau, 0.0)
        # Which part of the move a sample is in, its instant taken as the part that starts there (``INSTANT_S``).
        accelerating = tau + INSTANT_S < half
        moving = tau + INSTANT_S < 2 * half
        first = 0.5 * a * tau * tau
        second = distance - 0.5 * a * (2 * half - tau) ** 2
        progress = np.where(accelerating, first, np.where(moving, second, distance))
        speed = np.where(accelerating, a * tau, np.where(moving, a * (2 * half - tau), 0.0))
        accel = np.where(accelerating, a, np.where(moving, -a, 0.0))
        return self.offset + direction * progress, direction * speed, direction * accel


@dataclass(frozen=True)
class Square:
    """A square wave between ``offset ± amplitude`` at ``frequency_hz``."""

    amplitude: np.ndarray
    frequency_hz: float
    offset: np.ndarray

    def sample(self, t: float) -> Sample:
        sign = 1.0 if (t * self.frequency_hz) % 1.0 < 0.5 else -1.0
        zero = np.zeros_like(self.offset)
        return self.offset + sign * self.amplitude, zero, zero.copy()


@dataclass(frozen=True)
class Chirp:
    """A linear chirp from ``frequency_hz`` to ``end_frequency_hz`` over ``sweep_time_s``, then back, and so on: the
    frequency a triangle, the phase running on. At each turn position and velocity are continuous; only the
    acceleration's sweep-rate term ``A·2π·df/dt·cos(phase)`` changes sign (a finite step, like a shaped step's)."""

    amplitude: np.ndarray
    frequency_hz: float
    end_frequency_hz: float
    sweep_time_s: float
    offset: np.ndarray

    def sample(self, t: float) -> Sample:
        f0, f1, sweep = self.frequency_hz, self.end_frequency_hz, self.sweep_time_s
        k = (f1 - f0) / sweep
        cycles_per_sweep = 0.5 * (f0 + f1) * sweep  # the phase one sweep runs through, in cycles
        pair, within = divmod(t, 2.0 * sweep)  # an up and a down sweep per pair
        start = (2.0 * cycles_per_sweep * pair) % 1.0  # the phase (cycles) the sweeps before ran through
        if within < sweep:  # f0 → f1
            tau = within
            cycles = start + f0 * tau + 0.5 * k * tau * tau
            w = 2.0 * np.pi * (f0 + k * tau)
            dw = 2.0 * np.pi * k
        else:  # f1 → f0, from where the sweep up ended
            tau = within - sweep
            cycles = start + cycles_per_sweep + f1 * tau - 0.5 * k * tau * tau
            w = 2.0 * np.pi * (f1 - k * tau)
            dw = -2.0 * np.pi * k
        phase = 2.0 * np.pi * cycles
        s, c = np.sin(phase), np.cos(phase)
        return (
            self.offset + self.amplitude * s,
            self.amplitude * w * c,
            self.amplitude * (dw * c - w * w * s),
        )


@dataclass(frozen=True)
class Hold:
    """A constant position."""

    position: np.ndarray

    def sample(self, t: float) -> Sample:
        zero = np.zeros_like(self.position)
        return self.position.copy(), zero, zero.copy()


def time_scaled(trajectory: Trajectory, factor: float) -> Trajectory:
    """The same motion passed through in ``factor`` times the time (velocities ÷ factor, accelerations
    ÷ factor²): a sine's or square's frequency ÷ factor; a chirp's frequencies ÷ factor and sweep × factor; a
    minimum-time step's ``max_acceleration`` ÷ factor² (its start and grid rounding stay). A jump step and a
    hold have no motion to slow."""
    if not np.isfinite(factor) or factor <= 0:
        raise ConfigError(f"time scale: must be a finite number > 0, got {factor}")
    if factor == 1.0:
        return trajectory
    if isinstance(trajectory, Sine | Square):
        return replace(trajectory, frequency_hz=trajectory.frequency_hz / factor)
    if isinstance(trajectory, Chirp):
        return replace(
            trajectory,
            frequency_hz=trajectory.frequency_hz / factor,
            end_frequency_hz=trajectory.end_frequency_hz / factor,
            sweep_time_s=trajectory.sweep_time_s * factor,
        )
    if isinstance(trajectory, MinTimeStep):
        return replace(trajectory, max_acceleration=trajectory.max_acceleration / factor**2)
    if isinstance(trajectory, Step | Hold):
        return trajectory
    raise TypeError(f"cannot scale a {type(trajectory).__name__} in time")


def make_trajectory(
    mode: str,
    *,
    joint_count: int,
    amplitude: float | list[float] = 1.0,
    frequency_hz: float = 0.5,
    offset: float | list[float] = 0.0,
    step_time_s: float = 1.0,
    end_frequency_hz: float = 2.0,
    sweep_time_s: float = 10.0,
    step_shaping: str = "none",
    max_acceleration: float = 60.0,
    sample_period_s: float = 0.0,
) -> Trajectory:
    """A trajectory by name, scalars broadcast to ``joint_count`` joints (``ConfigError`` on a bad value)."""
    amp = per_joint("amplitude", amplitude, joint_count)
    off = per_joint("offset", offset, joint_count)
    for name, value in (
        ("frequency_hz", frequency_hz),
        ("step_time_s", step_time_s),
        ("end_frequency_hz", end_frequency_hz),
        ("sweep_time_s", sweep_time_s),
    ):
        if not np.isfinite(value) or value < 0:
            raise ConfigError(f"{name}: must be a finite number >= 0, got {value}")
    if mode == "sine":
        return Sine(amp, frequency_hz, off)
    if mode == "step":
        if step_shaping == "min_time":
            if not np.isfinite(max_acceleration) or max_acceleration <= 0:
                raise ConfigError(f"max_acceleration: must be > 0, got {max_acceleration}")
            return MinTimeStep(amp, step_time_s, off, max_acceleration, sample_period_s)
        if step_shaping != "none":
            raise ConfigError(f"step_shaping: {step_shaping!r} is not one of ['none', 'min_time']")
        return Step(amp, step_time_s, off)
    if mode == "square":
        if frequency_hz <= 0:
            raise ConfigError("frequency_hz: must be > 0 for a square wave")
        return Square(amp, frequency_hz, off)
    if mode == "chirp":
        if sweep_time_s <= 0:
            raise ConfigError("sweep_time_s: must be > 0 for a chirp")
        return Chirp(amp, frequency_hz, end_frequency_hz, sweep_time_s, off)
    if mode == "hold":
        return Hold(off)
    raise ConfigError(f"mode: {mode!r} is not one of {list(MODES)}")


def per_joint(name: str, value: float | list[float] | np.ndarray, joint_count: int) -> np.ndarray:
    """Broadcast a scalar, or check a list, to one finite float per joint."""
    array = np.atleast_1d(np.asarray(value, dtype=float))
    if array.size == 1:
        array = np.full(joint_count, float(array[0]))
    if array.shape != (joint_count,):
        raise ConfigError(f"{name}: expected 1 or {joint_count} values, got {array.size}")
    if not np.all(np.isfinite(array)):
        raise ConfigError(f"{name}: values must be finite, got {array.tolist()}")
    return array
