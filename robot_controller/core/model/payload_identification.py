"""Identification of a payload ``[mass_kg, x_m, y_m, z_m]`` on the last joint's link: nonlinear least squares of ``tau =
ID(q, v, a; payload)`` (MuJoCo's ``mj_inverse``) over every joint at once (a per-joint fit would fold one joint's load
into another's). Standard errors σ²·(JᵀJ)⁻¹; a centre coordinate that moves no torque (on ``planar2``, along the axes)
is set to 0 and named."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from robot_controller.core.model.identification import (
    MAX_GAP_RATIO,
    SATURATION_FRACTION,
    IdentificationError,
    intervals,
)
from robot_controller.core.model.mujoco_model import load_model
from robot_controller.core.model.payload import MAX_MASS_KG, MAX_OFFSET_M, Payload, set_payload

# Where the search starts: a light load near the link's origin (a zero mass would leave its place undefined).
START = Payload(0.5, (0.0, 0.0, 0.05))
MIN_SAMPLES = 50
PARAMETER_NAMES = ("mass_kg", "x_m", "y_m", "z_m")
# A parameter whose column of the fit's Jacobian is this small against the largest moves no torque.
UNSEEN_RELATIVE = 1e-6
# kg: a fitted mass below this is the fit soaking up the model's rounding, not a load.
FOUND_MIN_KG = 0.01


@dataclass(frozen=True)
class PayloadFit:
    payload: Payload
    stderr: tuple[float, float, float, float]  #: of mass_kg, x_m, y_m, z_m (NaN: not identifiable)
    residual_rms_nm: float  #: torque the fitted model leaves unexplained, RMS over joints and samples
    residual_rms_without_nm: float  #: the same for the URDF alone (no payload)
    samples: int  #: intervals used
    unidentifiable: tuple[str, ...] = ()  #: names (``PARAMETER_NAMES``) the motion's torques do not depend on, set to 0

    @property
    def found(self) -> bool:
        """A mass above 3 standard errors and ``FOUND_MIN_KG`` (with none, the centre means nothing)."""
        return self.payload.mass_kg > max(3.0 * self.stderr[0], FOUND_MIN_KG)


def fit_payload(
    urdf_path: str | Path,
    time_s: np.ndarray,
    position: np.ndarray,
    velocity: np.ndarray,
    torque: np.ndarray,
    *,
    effort_limit: np.ndarray | float | None = None,
    braked: np.ndarray | None = None,
) -> PayloadFit:
    """Fit a payload to a recorded motion (the TRUE state and the torque that acted over the interval
    each row ends, as :func:`robot_controller.core.model.identification.identify` takes them).

    :raises IdentificationError: too few usable samples, or a fit the motion does not pin down
    """
    time_s = np.asarray(time_s, dtype=float).reshape(-1)
    position, velocity, torque = (
        np.asarray(x, dtype=float).reshape(len(time_s), -1) for x in (position, velocity, torque)
    )
    n = position.shape[1]
    dt, q, v, a, _ = intervals(time_s, position, velocity)
    tau = torque[1:]
    limit = np.full(n, np.inf) if effort_limit is None else np.broadcast_to(np.asarray(effort_limit, float), (n,))
    held = np.zeros((len(time_s), n), bool) if braked is None else np.asarray(braked, bool).reshape(len(time_s), -1)
    use = (
        (dt > 0)
        & (dt < MAX_GAP_RATIO * np.median(dt))
        & ~np.any(held[1:] | held[:-1], axis=1)
        & ~np.any(tau == 0.0, axis=1)
        & ~np.any(np.abs(tau) >= SATURATION_FRACTION * limit, axis=1)
        & np.all(np.isfinite(a), axis=1)
        & np.all(np.isfinite(tau), axis=1)
    )
    if use.sum() < MIN_SAMPLES:
        raise IdentificationError(f"{int(use.sum())} usable samples, at least {MIN_SAMPLES} needed")
    q, v, a, tau = q[use], v[use], a[use], tau[use]
    model = load_model(urdf_path, payload=START)
    data = mujoco.MjData(model)

    def residual(theta: np.ndarray) -> np.ndarray:
        set_payload(model, Payload(float(theta[0]), (float(theta[1]), float(theta[2]), float(theta[3]))))
        out = np.empty_like(tau)
        for k in range(len(tau)):
            data.qpos[:], data.qvel[:], data.qacc[:] = q[k], v[k], a[k]
            mujoco.mj_inverse(model, data)
            out[k] = data.qfrc_inverse
        return (out - tau).reshape(-1)

    from scipy.optimize import least_squares  # (here: scipy is the identification's alone)

    without = residual(np.array([0.0, 0.0, 0.0, 0.0]))
    bound = MAX_OFFSET_M / np.sqrt(3.0)
    result = least_squares(
        residual,
        np.array(START.as_values()),
        bounds=([0.0, -bound, -bound, -bound], [MAX_MASS_KG, bound, bound, bound]),
        x_scale=[1.0, 0.1, 0.1, 0.1],
    )
    jacobian = result.jac
    column_norm = np.linalg.norm(jacobian, axis=0)
    seen = column_norm > UNSEEN_RELATIVE * column_norm.max()
    if not seen[0]:
        raise IdentificationError("the motion does not pin the payload down (its mass moves no torque)")
    theta = result.x.copy()
    theta[~seen] = 0.0  # an offset no torque depends on: the link's plane
    seen_jacobian = jacobian[:, seen]
    dof = max(1, jacobian.shape[0] - int(seen.sum()))
    sigma2 = float(result.fun @ result.fun) / dof
    try:
        covariance = sigma2 * np.linalg.inv(seen_jacobian.T @ seen_jacobian)
    except np.linalg.LinAlgError:
        raise IdentificationError("the motion does not pin the payload down (singular fit)") from None
    stderr = np.full(4, np.nan)
    stderr[seen] = np.sqrt(np.maximum(np.diag(covariance), 0.0))
    return PayloadFit(
        payload=Payload(float(theta[0]), (float(theta[1]), float(theta[2]), float(theta[3]))),
        stderr=tuple(float(s) for s in stderr),
        residual_rms_nm=float(np.sqrt(np.mean(result.fun**2))),
        residual_rms_without_nm=float(np.sqrt(np.mean(without**2))),
        samples=int(len(tau)),
        unidentifiable=tuple(name for name, known in zip(PARAMETER_NAMES, seen, strict=True) if not known),
    )
