"""Identification of the arm from a recorded motion: per joint, a linear least squares fit of ``tau = I·a + b·v +
f_c·sign(v) + G·cos(q)`` per interval between two samples (a drive reports the torque it held since the sample before).
Columns and torque go through the same Savitzky–Golay smoothing (the equation is linear: filtering both sides keeps it).
Standard errors σ²·(XᵀX)⁻¹ are optimistic (filtered residuals correlate) but rank the parameters."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from robot_controller.core.model.arm_model import PARAMETERS

# Below this speed (rad/s) a sample says nothing reliable about the sign of dry friction.
MIN_SPEED = 0.05
# Savitzky–Golay window (samples, odd) and polynomial order of the smoothing.
SMOOTHING_WINDOW = 7
SMOOTHING_ORDER = 2
# A torque within this fraction of the effort limit counts as saturated.
SATURATION_FRACTION = 0.999
# Intervals longer than this many times the median are gaps in the recording: left out.
MAX_GAP_RATIO = 1.5
# Fewer usable samples than this per joint is no fit.
MIN_SAMPLES = 20


@dataclass(frozen=True)
class JointFit:
    """One joint's identified model and how well the data pinned it down."""

    inertia: float  #: kg·m²
    damping: float  #: N·m·s/rad
    coulomb_friction: float  #: N·m
    gravity_torque: float  #: N·m (times cos q)
    inertia_stderr: float
    damping_stderr: float
    coulomb_friction_stderr: float
    gravity_torque_stderr: float
    residual_rms_nm: float  #: RMS of the torque the model does not explain, N·m
    samples: int  #: intervals used in the fit
    excluded_braked: int  #: left out: brake engaged or torque off
    excluded_saturated: int  #: left out: torque at the effort limit
    excluded_slow: int  #: left out: speed below min_speed or reversing
    excluded_other: int  #: left out: gaps in the recording, the smoothing's edges

    def values(self) -> dict[str, float]:
        return {name: getattr(self, name) for name in PARAMETERS}

    def as_dict(self) -> dict[str, float | int]:
        return asdict(self)


class IdentificationError(ValueError):
    """The data cannot pin the model down (too few usable samples, no excitation)."""


def intervals(
    time_s: np.ndarray, position: np.ndarray, velocity: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per interval between consecutive samples, arrays ``(N-1, n)``: ``(duration s (N-1,), mid position,
    mid velocity, mean acceleration, velocity changes sign or stops)``."""
    dt = np.diff(time_s)
    acceleration = np.diff(velocity, axis=0) / np.where(dt > 0, dt, np.nan)[:, None]
    mid_position = 0.5 * (position[1:] + position[:-1])
    mid_velocity = 0.5 * (velocity[1:] + velocity[:-1])
    reversing = np.sign(velocity[1:]) != np.sign(velocity[:-1])
    return dt, mid_position, mid_velocity, acceleration, reversing


def _widen(mask: np.ndarray, half_width: int) -> np.ndarray:
    """``mask`` (True = left out) widened by ``half_width`` samples on each side."""
    if half_width <= 0 or not mask.any():
        return mask
    kernel = np.ones(2 * half_width + 1)
    return np.convolve(mask.astype(float), kernel, mode="same") > 0


def identify(
    time_s: np.ndarray,
    position: np.ndarray,
    velocity: np.ndarray,
    torque: np.ndarray,
    *,
    effort_limit: np.ndarray | float | None = None,
    braked: np.ndarray | None = None,
    min_speed: float = MIN_SPEED,
    window: int = SMOOTHING_WINDOW,
    order: int = SMOOTHING_ORDER,
) -> list[JointFit]:
    """Fit each joint's :class:`~.arm_model.JointArmModel` to a recorded motion: ``position``, ``velocity`` and the
    applied ``torque`` ``(N, n)`` (row k: the torque from sample k-1 to k) at increasing ``time_s``. Left out:
    intervals at ``effort_limit`` (saturated), ``braked``, slower than ``min_speed`` or reversing. ``window`` and
    ``order``: the Savitzky–Golay smoothing (window 1: none). ``IdentificationError`` when the data cannot pin a
    joint's model down."""
    time_s = np.asarray(time_s, dtype=float).reshape(-1)
    position, velocity, torque = (
        np.asarray(x, dtype=float).reshape(len(time_s), -1) for x in (position, velocity, torque)
    )
    n = position.shape[1]
    if len(time_s) < 3:
        raise IdentificationError(f"{len(time_s)} samples: nothing to fit")
    if np.any(np.diff(time_s) <= 0):
        order_ = np.argsort(time_s, kind="stable")
        keep = np.concatenate([[True], np.diff(time_s[order_]) > 0])
        order_ = order_[keep]
        time_s, position, velocity, torque = time_s[order_], position[order_], velocity[order_], torque[order_]
        if braked is not None:
            braked = np.asarray(braked)[order_]
    limit = np.full(n, np.inf) if effort_limit is None else np.broadcast_to(np.asarray(effort_limit, dtype=float), (n,))
    held = (
        np.zeros((len(time_s), n), dtype=bool)
        if braked is None
        else np.broadcast_to(np.asarray(braked, dtype=bool).reshape(len(time_s), -1), (len(time_s), n))
    )

    dt, q, v, a, reversing = intervals(time_s, position, velocity)
    tau = torque[1:]  # the torque over each interval: reported at its end
    gap = ~(dt < MAX_GAP_RATIO * np.median(dt))
    window = max(1, int(window))
    window += 1 - window % 2  # odd
    smooth = window > 2 and len(dt) > window
    half = window // 2 if smooth else 0

    fits = []
    for j in range(n):
        off = held[1:, j] | held[:-1, j] | (tau[:, j] == 0.0)
        saturated = np.abs(tau[:, j]) >= SATURATION_FRACTION * limit[j]
        slow = reversing[:, j] | (np.abs(velocity[1:, j]) < min_speed) | (np.abs(velocity[:-1, j]) < min_speed)
        other = gap | ~np.isfinite(a[:, j]) | ~np.isfinite(tau[:, j])
        columns = [a[:, j], v[:, j], np.sign(v[:, j]), np.cos(q[:, j]), tau[:, j]]
        if smooth:
            from scipy.signal import savgol_filter  # (here: scipy is the identification's alone)

            filled = [np.where(other, 0.0, c) for c in columns]
            columns = [savgol_filter(c, window, min(order, window - 1), mode="interp") for c in filled]
            edge = np.zeros(len(dt), dtype=bool)
            edge[:half], edge[-half:] = True, True
            other = _widen(other, half) | edge
            off, saturated, slow = (_widen(m, half) for m in (off, saturated, slow))
        use = ~(off | saturated | slow | other)
        a_f, v_f, s_f, c_f, tau_f = columns
        X = np.column_stack([a_f, v_f, s_f, c_f])
        theta, stderr, rms = _fit(X, tau_f, use)
        fits.append(
            JointFit(
                *theta,
                *stderr,
                residual_rms_nm=rms,
                samples=int(use.sum()),
                excluded_braked=int(off.sum()),
                excluded_saturated=int((saturated & ~off).sum()),
                excluded_slow=int((slow & ~off & ~saturated).sum()),
                excluded_other=int((other & ~off & ~saturated & ~slow).sum()),
            )
        )
    return fits


def _fit(X: np.ndarray, y: np.ndarray, use: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Least squares of ``y`` on ``X``'s columns over the rows ``use``: ``(parameters, stderrs, residual RMS)``."""
    X, y = X[use], y[use]
    count, p = X.shape
    needed = max(MIN_SAMPLES, 2 * p)
    if count < needed:
        raise IdentificationError(
            f"{count} usable samples, at least {needed} needed (the motion was too slow, saturated or braked)"
        )
    theta, _, rank, _ = np.linalg.lstsq(X, y, rcond=None)
    if rank < p:
        raise IdentificationError(
            "the motion does not excite every parameter (rank-deficient regression): "
            "it needs acceleration, speed in both directions and a range of positions"
        )
    residual = y - X @ theta
    sigma2 = float(residual @ residual) / (count - p)
    covariance = sigma2 * np.linalg.inv(X.T @ X)
    return theta, np.sqrt(np.diag(covariance)), float(np.sqrt(np.mean(residual**2)))
