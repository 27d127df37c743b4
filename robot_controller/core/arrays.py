"""Array helpers for the per-tick path: the controller's arrays hold one value
per joint (one to seven), where NumPy's Python-level wrappers (``np.clip``,
``np.all``, ``np.stack``) cost more than the arithmetic. Each helper returns
what the NumPy function it stands for returns, to the bit.
"""

from __future__ import annotations

import numpy as np


def clip(value: np.ndarray, low: np.ndarray | float, high: np.ndarray | float, out: np.ndarray | None = None):
    """``np.clip(value, low, high)`` (NaN stays NaN), in two ufunc calls."""
    return np.minimum(np.maximum(value, low), high, out=out)


def within(value: np.ndarray, limit: np.ndarray | float, out: np.ndarray | None = None):
    """``value`` clipped to ``±limit``: ``np.clip(value, -limit, limit)``."""
    return np.minimum(np.maximum(value, -limit), limit, out=out)


def all_finite(*arrays: np.ndarray | float) -> bool:
    """Whether every value of every one of ``arrays`` (which broadcast together) is
    finite: one reduction for them all, not one ``np.all`` apiece."""
    finite = np.isfinite(arrays[0])
    for array in arrays[1:]:
        finite = finite & np.isfinite(array)
    return bool(finite.all())


def as_shape(value: np.ndarray | float, shape: tuple[int, ...]) -> np.ndarray:
    """``value`` as a float array of ``shape``: itself when it already is one, otherwise
    ``np.broadcast_to`` it (a read-only view)."""
    if isinstance(value, np.ndarray) and value.shape == shape and value.dtype == np.float64:
        return value
    return np.broadcast_to(np.asarray(value, dtype=float), shape)


def matrix_power(a: np.ndarray, k: int) -> np.ndarray:
    """``np.linalg.matrix_power(a, k)`` for a square ``a`` and ``k >= 0``: the same
    products in the same order (binary powering), by ``ndarray.dot``, without
    its checks and dispatch."""
    if k == 0:
        return np.eye(a.shape[0])
    if k <= 3:
        return a.copy() if k == 1 else a.dot(a) if k == 2 else a.dot(a).dot(a)
    power = result = None
    while k > 0:
        power = a if power is None else power.dot(power)
        k, bit = divmod(k, 2)
        if bit:
            result = power if result is None else result.dot(power)
    return result


def clip_scalar(value: float, low: float, high: float) -> float:
    """``float(np.clip(value, low, high))`` for a Python float (NaN stays NaN)."""
    if value != value:  # NaN
        return value
    return min(max(value, low), high)


def is_one_value(value: object) -> bool:
    """Whether ``value`` is an array of exactly one float: one joint's value, which the per-tick
    paths take on Python floats."""
    return type(value) is np.ndarray and value.shape == (1,)


def sign_scalar(value: float) -> float:
    """``np.sign`` of a Python float (NaN for NaN)."""
    if value != value:
        return value
    return float((value > 0) - (value < 0))
