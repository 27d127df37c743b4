"""Encoder model: what the controller sees instead of the true joint state."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from robot_controller.core.errors import ConfigError


@dataclass(frozen=True)
class SensorConfig:
    """Noise and imperfections of the joint sensor.

    :param position_noise_std: Gaussian σ on position, rad
    :param velocity_noise_std: Gaussian σ on velocity, rad/s
    :param position_bias: constant offset added to position, rad
    :param quantization: position resolution, rad (0 = continuous)
    """

    position_noise_std: float = 0.005
    velocity_noise_std: float = 0.02
    position_bias: float = 0.0
    quantization: float = 0.0

    def __post_init__(self) -> None:
        for name in ("position_noise_std", "velocity_noise_std", "quantization"):
            value = getattr(self, name)
            if not np.isfinite(value) or value < 0:
                raise ConfigError(f"{name}: must be a finite number >= 0, got {value}")
        if not np.isfinite(self.position_bias):
            raise ConfigError(f"position_bias: must be finite, got {self.position_bias}")


def measure(
    config: SensorConfig, position: np.ndarray, velocity: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Return a noisy ``(position, velocity)`` reading of the true state.

    ``rng`` is a seeded generator so a run can be repeated exactly.
    """
    noisy_position = position + config.position_bias + rng.normal(0.0, config.position_noise_std, np.shape(position))
    noisy_velocity = velocity + rng.normal(0.0, config.velocity_noise_std, np.shape(velocity))
    if config.quantization > 0:
        noisy_position = np.round(noisy_position / config.quantization) * config.quantization
    return noisy_position, noisy_velocity
