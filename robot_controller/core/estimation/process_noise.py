"""The filter's process noise over a period: the arm's unmodelled acceleration, the external torque's random walk
(the disturbance observer's) and a command whose instant of effect is uncertain."""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from robot_controller.core.estimation.config import KalmanConfig


def process_noise(
    config: KalmanConfig, dt: float, acceleration_per_nm=None, disturbance_noise_std=None, acceleration_noise_std=None
) -> np.ndarray:
    """The process noise over ``dt`` s: ``(2, 2)`` on ``[q, v]`` from the white unmodelled acceleration; with
    ``acceleration_per_nm`` (rad/s² per N·m on each joint's own axis: the observer) ``(n, 3, 3)`` on ``[q, v, d]``,
    adding ``d``'s random walk. The σs per joint, None: the config's."""
    G = (0.5 * dt * dt, dt)
    if acceleration_per_nm is None:
        return np.outer(G, G) * config.acceleration_noise_std**2
    b = np.asarray(acceleration_per_nm, dtype=float).reshape(-1)
    sigma_a = config.acceleration_noise_std if acceleration_noise_std is None else acceleration_noise_std
    sigma_d = config.disturbance_noise_std if disturbance_noise_std is None else disturbance_noise_std
    return observer_noise(dt, b, np.square(sigma_d), np.square(sigma_a))


def observer_noise(dt: float, b: np.ndarray, disturbance_variance, acceleration_variance) -> np.ndarray:
    """:func:`process_noise` with the observer, ``(n, 3, 3)``, from ``b`` (n,) and the variances (σ², per joint or
    one for all)."""
    # Per joint, Q = σa²·A + w·b²·B + w·b·C + w·D (w = σd²): one product with the templates.
    weights = np.empty((b.size, 4))
    weights[:, 0] = acceleration_variance
    weights[:, 3] = w = disturbance_variance
    weights[:, 2] = wb = w * b
    weights[:, 1] = wb * b
    return weights.dot(_noise_templates(dt)).reshape(b.size, 3, 3)


@lru_cache(maxsize=64)  # a filter's periods are a handful of roundings of one period
def _noise_templates(dt: float) -> np.ndarray:
    """The process noise's four parts over ``dt`` s, (4, 9), read only: the white acceleration, and ``d``'s random
    walk in ``[q, v]``, between ``[q, v]`` and ``d``, and in ``d``."""
    g0, g1 = 0.5 * dt * dt, dt
    qq, qv, vv = dt**5 / 20, dt**4 / 8, dt**3 / 3
    qd, vd = dt**3 / 6, dt**2 / 2
    templates = np.array(
        [
            [g0 * g0, g0 * g1, 0.0, g0 * g1, g1 * g1, 0.0, 0.0, 0.0, 0.0],
            [qq, qv, 0.0, qv, vv, 0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, qd, 0.0, 0.0, vd, qd, vd, 0.0],
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, dt],
        ]
    )
    templates.flags.writeable = False
    return templates


@lru_cache(maxsize=64)
def timing_noise_template(dt: float) -> np.ndarray:
    """``G·Gᵀ``, G = [dt, 1], read only: a velocity step of unknown size at the start of the period."""
    G = np.array([dt, 1.0])
    template = np.outer(G, G)
    template.flags.writeable = False
    return template
