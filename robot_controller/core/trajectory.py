"""Reference trajectories: position, velocity and acceleration at time ``t``.

Every trajectory is a pure function of ``t`` (s since the trajectory
started) and returns three arrays of shape ``(n,)``: rad, rad/s, rad/s².
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from robot_controller.core.errors import ConfigError

Sample = tuple[np.ndarray, np.ndarray, np.ndarray]

MODES = ("sine", "step", "square", "chirp", "hold")


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
        return self.offset + self.amplitude * s, self.amplitude * w * c, -self.amplitude * w * w * s


@dataclass(frozen=True)
class Step:
    """``offset`` until ``step_time_s``, then ``offset + amplitude`` (zero velocity throughout)."""

    amplitude: np.ndarray
    step_time_s: float
    offset: np.ndarray

    def sample(self, t: float) -> Sample:
        zero = np.zeros_like(self.offset)
        position = self.offset + (self.amplitude if t >= self.step_time_s else zero)
        return position, zero, zero.copy()


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
    """A linear chirp from ``frequency_hz`` to ``end_frequency_hz`` over ``sweep_time_s``, then repeating."""

    amplitude: np.ndarray
    frequency_hz: float
    end_frequency_hz: float
    sweep_time_s: float
    offset: np.ndarray

    def sample(self, t: float) -> Sample:
        tau = t % self.sweep_time_s
        k = (self.end_frequency_hz - self.frequency_hz) / self.sweep_time_s
        phase = 2.0 * np.pi * (self.frequency_hz * tau + 0.5 * k * tau * tau)
        w = 2.0 * np.pi * (self.frequency_hz + k * tau)
        dw = 2.0 * np.pi * k
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
) -> Trajectory:
    """Build a trajectory by name; scalars broadcast to ``joint_count`` joints.

    :raises ConfigError: unknown mode, wrong array length or a non-finite value
    """
    amp = per_joint("amplitude", amplitude, joint_count)
    off = per_joint("offset", offset, joint_count)
    for name, value in (("frequency_hz", frequency_hz), ("step_time_s", step_time_s),
                        ("end_frequency_hz", end_frequency_hz), ("sweep_time_s", sweep_time_s)):
        if not np.isfinite(value) or value < 0:
            raise ConfigError(f"{name}: must be a finite number >= 0, got {value}")
    if mode == "sine":
        return Sine(amp, frequency_hz, off)
    if mode == "step":
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
