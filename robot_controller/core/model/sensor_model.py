"""Encoder model: what the controller sees instead of the true joint state."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from robot_controller.core.errors import ConfigError


@dataclass(frozen=True)
class SensorConfig:
    """Noise and imperfections of the joint sensor, every one given (the defaults are the parameter schema's)."""

    position_noise_std: float  #: rad, Gaussian
    velocity_noise_std: float  #: rad/s, Gaussian
    position_bias: float  #: rad, added to position
    quantization: float  #: rad, position resolution (0: continuous)
    #: s, how old each reading is when published; its stamp says so, as a hardware-timestamped encoder's does
    delay_s: float

    def __post_init__(self) -> None:
        for name in ("position_noise_std", "velocity_noise_std", "quantization", "delay_s"):
            value = getattr(self, name)
            if not np.isfinite(value) or value < 0:
                raise ConfigError(f"{name}: must be a finite number >= 0, got {value}")
        if not np.isfinite(self.position_bias):
            raise ConfigError(f"position_bias: must be finite, got {self.position_bias}")

    @cached_property
    def noise_std(self) -> np.ndarray:
        """σ of position (rad) and velocity (rad/s), in that order."""
        return np.array([self.position_noise_std, self.velocity_noise_std])


def measure(
    config: SensorConfig, position: np.ndarray, velocity: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """A noisy ``(position, velocity)`` reading of the true state (``rng`` seeded: a run repeats exactly)."""
    position, velocity = np.asarray(position), np.asarray(velocity)
    # One draw for both, position's first, scaled: the numbers ``rng.normal`` gives, in that order.
    noise = rng.standard_normal((2, *position.shape)) * config.noise_std.reshape((2,) + (1,) * position.ndim)
    noisy_position = position + config.position_bias + noise[0]
    noisy_velocity = velocity + noise[1]
    if config.quantization > 0:
        noisy_position = np.round(noisy_position / config.quantization) * config.quantization
    return noisy_position, noisy_velocity


class DelayLine:
    """The true states of the last ``delay_s`` seconds, to publish each one late (``push``)."""

    def __init__(self, delay_s: float) -> None:
        self.delay_s = delay_s
        self._samples: deque[tuple[float, np.ndarray, np.ndarray]] = deque()

    def push(self, stamp_s: float, position: np.ndarray, velocity: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        """Add the sample at ``stamp_s`` and return the one ``delay_s`` older (with its stamp)."""
        self._samples.append((stamp_s, position, velocity))
        due_s = stamp_s - self.delay_s + 1e-9
        while len(self._samples) > 1 and self._samples[1][0] <= due_s:
            self._samples.popleft()
        return self._samples[0]
