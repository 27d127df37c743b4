"""Identification of a chain of joints: each joint's armature (rotor inertia over the URDF's links), viscous damping and
Coulomb friction, together with a payload ``[mass_kg, x_m, y_m, z_m]`` on the last joint's link.

The rigid-body part is MuJoCo's inverse dynamics of the URDF (its links, its own armature, the payload candidate; its
damping and friction set to 0, since they are fitted). What is left of joint j's torque is linear in
``[a_j, v_j, sign(v_j)]``: for a payload candidate each joint's three numbers are a least-squares solve over that
joint's own usable intervals, and ``scipy.optimize.least_squares`` searches the payload over what those solves leave
(variable projection). A joint's equation holds whatever the other joints do, so each joint leaves out only its own
slow, reversing, braked or saturated intervals. Standard errors: σ²·(XᵀX)⁻¹ per joint at the fitted payload, and
the payload's from the projected residual's Jacobian (both optimistic: model errors correlate in time)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from robot_controller.core.model.chain_parsimony import FRICTION_FLOOR_SHARE, parsimonious
from robot_controller.core.model.identification import (
    MAX_GAP_RATIO,
    MIN_SPEED,
    SATURATION_FRACTION,
    IdentificationError,
    intervals,
)
from robot_controller.core.model.mujoco_model import joint_names, load_model
from robot_controller.core.model.payload import BODY_NAME as PAYLOAD_BODY
from robot_controller.core.model.payload import MAX_MASS_KG, MAX_OFFSET_M, Payload, add_to, carrying_link, set_payload
from robot_controller.core.model.payload_identification import (
    PARAMETER_NAMES,
    START,
    PayloadFit,
)

#: Per joint, the linear parameters in the order of their columns ``[a, v, sign(v)]``.
JOINT_PARAMETERS = ("armature", "damping", "coulomb_friction")
#: Fewer usable intervals than this on a joint: its three numbers are not identified.
MIN_JOINT_SAMPLES = 50
#: The payload's parameters at their typical sizes (kg, m, m, m): the search's scale, and the unseen test's.
PAYLOAD_SCALE = np.array([1.0, 0.1, 0.1, 0.1])
#: A centre coordinate whose typical size moves less torque than this share of what a typical mass moves is not
#: identifiable: the motion tells it only through a joint that hardly moved (a wrist held by its friction at a
#: near-constant angle turns it into another coordinate), and a simulated arm's near-perfect fit would otherwise
#: place it at its bound with a small standard error.
UNSEEN_SHARE = 1e-3
#: Fewer usable intervals than this in either direction: a joint's dry friction cannot be told from a constant torque.
MIN_DIRECTION_SAMPLES = 10
#: A joint whose columns' smallest singular value is below this share of the largest does not pin its three down.
MIN_CONDITION = 1e-6


@dataclass(frozen=True)
class ChainJointFit:
    """One joint of a chain: what was fitted (``identified``) or, when the motion could not tell, the URDF's values
    and ``reason``; ``clipped`` names the values fitted below 0 and set to 0 (the model cannot take them away)."""

    name: str
    armature: float  #: kg·m² added to the URDF's (its links' and its own armature), >= 0
    damping: float  #: N·m·s/rad, the joint's whole viscous damping
    coulomb_friction: float  #: N·m, the joint's whole dry friction
    inertia: float  #: kg·m², M(0)'s diagonal with the payload plus ``armature``: the controller's ``model_inertia``
    armature_stderr: float
    damping_stderr: float
    coulomb_friction_stderr: float
    urdf_inertia: float  #: kg·m², M(0)'s diagonal of the URDF alone
    urdf_damping: float  #: N·m·s/rad
    urdf_coulomb_friction: float  #: N·m
    residual_rms_nm: float  #: the torque left unexplained on this joint, RMS over its intervals
    samples: int  #: intervals used for this joint
    excluded_braked: int  #: left out: brake engaged or torque off
    excluded_saturated: int  #: left out: torque at the effort limit
    excluded_slow: int  #: left out: slower than the minimum speed or reversing
    excluded_other: int  #: left out: gaps in the recording, non-finite values
    identified: bool = True
    reason: str = ""  #: why not identified
    clipped: tuple[str, ...] = ()  #: names in ``JOINT_PARAMETERS`` fitted below 0, set to 0
    fitted: tuple[float, ...] = ()  #: the least squares' values of ``JOINT_PARAMETERS``, all free, none set to 0
    kept: tuple[
        str, ...
    ] = ()  #: names in ``JOINT_PARAMETERS`` not told from the URDF's: its values (:mod:`.chain_parsimony`)
    kept_cost: tuple[float, ...] = ()  #: per parameter, the share of residual RMS its URDF value added when decided

    def below_zero(self, name: str) -> str:
        """How far below 0 ``name`` was fitted, in words ("" if it was not)."""
        if name not in self.clipped:
            return ""
        value = self.fitted[JOINT_PARAMETERS.index(name)]
        err = getattr(self, f"{name}_stderr")
        noise = "within" if -value <= 3.0 * err else "beyond"
        return f"fitted {value:.2g} ± {err:.2g}, {noise} 3 standard errors of 0"

    @property
    def inertia_stderr(self) -> float:
        """The armature's (the links' share is the URDF's, given)."""
        return self.armature_stderr


@dataclass(frozen=True)
class ChainFit:
    joints: tuple[ChainJointFit, ...]
    payload: PayloadFit  #: the payload search; its ``found`` says whether the joints' values carry it
    residual_rms_nm: float  #: over every identified joint, at the values reported
    residual_rms_without_payload_nm: float  #: the same with each joint's three numbers fitted with no payload
    residual_rms_urdf_nm: float  #: the same for the URDF alone (its damping and friction, no payload)

    @property
    def payload_found(self) -> bool:
        return self.payload.found


def usable(
    time_s: np.ndarray,
    velocity: np.ndarray,
    torque: np.ndarray,
    acceleration: np.ndarray,
    reversing: np.ndarray,
    effort_limit: np.ndarray,
    held: np.ndarray,
    min_speed: float,
) -> dict[str, np.ndarray]:
    """Per interval and joint, why it is left out (``off``, ``saturated``, ``slow``, ``other``, each excluding the
    ones before) and ``use``."""
    dt = np.diff(time_s)
    tau = torque[1:]
    off = held[1:] | held[:-1] | (tau == 0.0)
    saturated = (np.abs(tau) >= SATURATION_FRACTION * effort_limit) & ~off
    slow = (reversing | (np.abs(velocity[1:]) < min_speed) | (np.abs(velocity[:-1]) < min_speed)) & ~off & ~saturated
    gap = ~((dt > 0) & (dt < MAX_GAP_RATIO * np.median(dt)))
    other = (gap[:, None] | ~np.isfinite(acceleration) | ~np.isfinite(tau)) & ~off & ~saturated & ~slow
    return {"off": off, "saturated": saturated, "slow": slow, "other": other, "use": ~(off | saturated | slow | other)}


class _Projection:
    """The torque MuJoCo's rigid-body inverse dynamics leaves, and what each joint's linear fit leaves of it."""

    def __init__(self, urdf_path: str | Path, q: np.ndarray, v: np.ndarray, a: np.ndarray, tau: np.ndarray) -> None:
        self.model = _search_model(urdf_path)
        dofs = self.model.jnt_dofadr[: self.model.njnt]
        # Damping and dry friction are fitted per joint: the inverse dynamics carries the links and armature alone.
        self.model.dof_damping[dofs] = 0.0
        self.model.dof_frictionloss[dofs] = 0.0
        self.data = mujoco.MjData(self.model)
        self.q, self.v, self.a, self.tau = q, v, a, tau
        self.fitted: list[tuple[int, np.ndarray, np.ndarray]] = []  #: (joint, rows, orthonormal basis of columns)

    def columns(self, joint: int, rows: np.ndarray) -> np.ndarray:
        return np.column_stack([self.a[rows, joint], self.v[rows, joint], np.sign(self.v[rows, joint])])

    def left(self, theta: np.ndarray) -> np.ndarray:
        """``tau - ID(q, v, a; payload theta)``, every interval and joint."""
        set_payload(self.model, _payload(theta))
        out = np.empty_like(self.tau)
        data = self.data
        for k in range(len(self.tau)):
            data.qpos[:], data.qvel[:], data.qacc[:] = self.q[k], self.v[k], self.a[k]
            mujoco.mj_inverse(self.model, data)
            out[k] = data.qfrc_inverse
        return self.tau - out

    def projected(self, theta: np.ndarray) -> np.ndarray:
        """What each fitted joint's least squares on its own columns leaves, stacked."""
        left = self.left(theta)
        return np.concatenate([left[rows, j] - basis @ (basis.T @ left[rows, j]) for j, rows, basis in self.fitted])

    def solve(self, theta: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
        """Per fitted joint at payload ``theta``: ``(parameters, standard errors, columns, torque left)``."""
        left, out = self.left(theta), []
        for j, rows, _ in self.fitted:
            X, y = self.columns(j, rows), left[rows, j]
            beta, *_ = np.linalg.lstsq(X, y, rcond=None)
            residual = y - X @ beta
            sigma2 = float(residual @ residual) / max(1, len(y) - X.shape[1])
            out.append((beta, np.sqrt(np.diag(sigma2 * np.linalg.inv(X.T @ X))), X, y))
        return out


def _search_model(urdf_path: str | Path) -> mujoco.MjModel:
    """The arm with a payload body the search can move (:func:`~.payload.set_payload`)."""
    model = load_model(urdf_path, payload=START)
    if any(model.body(i).name == PAYLOAD_BODY for i in range(model.nbody)):
        return model
    # A URDF that leaves MuJoCo's compiler at its default fuses a welded body into its link (the arms --robot
    # describes do not): the same dynamics, but no body left to move. Compiled again with its bodies kept.
    spec = mujoco.MjSpec.from_file(str(urdf_path))
    spec.compiler.fusestatic = False
    add_to(spec, carrying_link(model), START)
    return spec.compile()


def _payload(theta: np.ndarray) -> Payload:
    return Payload(float(theta[0]), (float(theta[1]), float(theta[2]), float(theta[3])))


def _diagonal_at_zero(urdf_path: str | Path, payload: Payload | None) -> np.ndarray:
    """M(0)'s diagonal, kg·m², as the controller's model computes it (URDF, its armature, ``payload``)."""
    model = load_model(urdf_path, payload=payload)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    matrix = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, matrix)
    return np.diag(matrix)[: model.njnt].copy()


def fit_chain(
    urdf_path: str | Path,
    time_s: np.ndarray,
    position: np.ndarray,
    velocity: np.ndarray,
    torque: np.ndarray,
    *,
    effort_limit: np.ndarray | float | None = None,
    braked: np.ndarray | None = None,
    min_speed: float = MIN_SPEED,
) -> ChainFit:
    """Fit each joint's armature, damping and friction and a payload on the last link to a recorded motion (the TRUE
    state and the torque that acted over the interval each row ends, as
    :func:`robot_controller.core.model.identification.identify` takes them), over ``urdf_path``'s links.

    :raises IdentificationError: no joint's motion pins its three numbers down
    """
    time_s = np.asarray(time_s, dtype=float).reshape(-1)
    position, velocity, torque = (
        np.asarray(x, dtype=float).reshape(len(time_s), -1) for x in (position, velocity, torque)
    )
    n = position.shape[1]
    if len(time_s) < MIN_JOINT_SAMPLES + 1:
        raise IdentificationError(f"{len(time_s)} samples: at least {MIN_JOINT_SAMPLES + 1} needed")
    limit = np.full(n, np.inf) if effort_limit is None else np.broadcast_to(np.asarray(effort_limit, float), (n,))
    held = np.zeros((len(time_s), n), bool) if braked is None else np.asarray(braked, bool).reshape(len(time_s), -1)
    _, q, v, a, reversing = intervals(time_s, position, velocity)
    why = usable(time_s, velocity, torque, a, reversing, limit, held, min_speed)
    rows_any = why["use"].any(axis=1)
    use = why["use"][rows_any]
    projection = _Projection(urdf_path, q[rows_any], v[rows_any], a[rows_any], torque[1:][rows_any])
    names = joint_names(projection.model)[:n]
    reasons: dict[int, str] = {}
    for j in range(n):
        rows = np.flatnonzero(use[:, j])
        if len(rows) < MIN_JOINT_SAMPLES:
            reasons[j] = (
                f"{len(rows)} usable intervals, at least {MIN_JOINT_SAMPLES} needed: it seldom moved faster than "
                f"{min_speed:g} rad/s with its torque free (not braked, not saturated)"
            )
            continue
        X = projection.columns(j, rows)
        if min(np.sum(X[:, 2] > 0), np.sum(X[:, 2] < 0)) < MIN_DIRECTION_SAMPLES:
            reasons[j] = (
                "it moved one way only (fewer than "
                f"{MIN_DIRECTION_SAMPLES} usable intervals the other way): its friction cannot be told from a "
                "constant torque"
            )
            continue
        norms = np.linalg.norm(X, axis=0)
        singular = np.linalg.svd(X / np.where(norms > 0, norms, 1.0), compute_uv=False)
        if singular[-1] < MIN_CONDITION * singular[0]:
            reasons[j] = "its motion does not tell inertia, damping and friction apart (it moved at one speed)"
            continue
        basis, _ = np.linalg.qr(X)
        projection.fitted.append((j, rows, basis))
    if not projection.fitted:
        raise IdentificationError("no joint's motion pins its armature, damping and friction down: " + reasons[0])

    payload = _fit_payload(projection)
    zero = np.zeros(4)
    without = projection.projected(zero)
    at = np.array(payload.payload.as_values()) if payload.found else zero
    solved = projection.solve(at)
    carried = payload.payload if payload.found else None
    diagonal = _diagonal_at_zero(urdf_path, carried)
    urdf_diagonal = _diagonal_at_zero(urdf_path, None)
    dofs = projection.model.jnt_dofadr[:n]
    urdf_model = load_model(urdf_path)
    urdf_damping, urdf_friction = urdf_model.dof_damping[dofs], urdf_model.dof_frictionloss[dofs]
    fitted = {j: fit for (j, _, _), fit in zip(projection.fitted, solved, strict=True)}
    joints, residuals = [], {}
    for j in range(n):
        common = dict(
            name=names[j],
            urdf_inertia=float(urdf_diagonal[j]),
            urdf_damping=float(urdf_damping[j]),
            urdf_coulomb_friction=float(urdf_friction[j]),
            samples=int(use[:, j].sum()),
            **{
                f"excluded_{key}": int(why[mask][:, j].sum())
                for key, mask in (("braked", "off"), ("saturated", "saturated"), ("slow", "slow"), ("other", "other"))
            },
        )
        if j not in fitted:  # the URDF's values stand
            nan = float("nan")
            unknown = dict(armature_stderr=nan, damping_stderr=nan, coulomb_friction_stderr=nan, residual_rms_nm=nan)
            joints.append(
                ChainJointFit(
                    armature=0.0,
                    damping=float(urdf_damping[j]),
                    coulomb_friction=float(urdf_friction[j]),
                    inertia=float(diagonal[j]),
                    **unknown,
                    **common,
                    identified=False,
                    reason=reasons[j],
                )
            )
            continue
        beta, stderr, X, y = fitted[j]
        reference = np.array([0.0, urdf_damping[j], urdf_friction[j]])
        floor = FRICTION_FLOOR_SHARE * limit[j] if np.isfinite(limit[j]) else 0.0
        chosen = parsimonious(X, y, reference, friction_column=2, friction_floor_nm=floor)
        residuals[j] = residual = chosen.residual
        armature, damping, friction = (max(0.0, float(value)) for value in chosen.values)
        joints.append(
            ChainJointFit(
                armature=armature,
                damping=damping,
                coulomb_friction=friction,
                inertia=float(diagonal[j]) + armature,
                armature_stderr=float(stderr[0]),
                damping_stderr=float(stderr[1]),
                coulomb_friction_stderr=float(stderr[2]),
                residual_rms_nm=float(np.sqrt(np.mean(residual**2))),
                **common,
                clipped=tuple(name for name, value in zip(JOINT_PARAMETERS, chosen.values, strict=True) if value < 0),
                fitted=tuple(float(value) for value in beta),
                kept=tuple(name for name, kept in zip(JOINT_PARAMETERS, chosen.kept, strict=True) if kept),
                kept_cost=chosen.cost,
            )
        )
    final = np.concatenate([residuals[j] for j, _, _ in projection.fitted])
    left = projection.left(zero)
    urdf_alone = np.concatenate(
        [
            left[rows, j] - projection.columns(j, rows) @ [0.0, urdf_damping[j], urdf_friction[j]]
            for j, rows, _ in projection.fitted
        ]
    )
    return ChainFit(
        joints=tuple(joints),
        payload=payload,
        residual_rms_nm=float(np.sqrt(np.mean(final**2))),
        residual_rms_without_payload_nm=float(np.sqrt(np.mean(without**2))),
        residual_rms_urdf_nm=float(np.sqrt(np.mean(urdf_alone**2))),
    )


def _search(projection: _Projection, free: np.ndarray, start: np.ndarray):
    """``least_squares`` over the payload's ``free`` parameters, the others at 0: its result and the whole vector."""
    from scipy.optimize import least_squares  # (here: scipy is the identification's alone)

    bound = MAX_OFFSET_M / np.sqrt(3.0)
    low, high = np.array([0.0, -bound, -bound, -bound]), np.array([MAX_MASS_KG, bound, bound, bound])

    def whole(x: np.ndarray) -> np.ndarray:
        theta = np.zeros(4)
        theta[free] = x
        return theta

    result = least_squares(
        lambda x: projection.projected(whole(x)),
        np.clip(start[free], low[free], high[free]),
        bounds=(low[free], high[free]),
        x_scale=PAYLOAD_SCALE[free],
    )
    return result, whole(result.x)


def _fit_payload(projection: _Projection) -> PayloadFit:
    """The payload search over the projected residual (each joint's three numbers solved for each candidate); a
    centre coordinate the motion cannot tell is set to 0 and the others searched again without it."""
    without = projection.projected(np.zeros(4))
    everything = np.ones(4, dtype=bool)
    result, theta = _search(projection, everything, np.array(START.as_values()))
    column_norm = np.linalg.norm(result.jac * PAYLOAD_SCALE, axis=0)
    seen = column_norm > UNSEEN_SHARE * column_norm.max()
    if seen[0] and not seen.all():
        result, theta = _search(projection, seen, theta)
    stderr = np.full(4, np.nan)
    if seen[0]:
        jacobian = result.jac  # the searched parameters' columns
        dof = max(1, jacobian.shape[0] - int(seen.sum()) - 3 * len(projection.fitted))
        sigma2 = float(result.fun @ result.fun) / dof
        try:
            covariance = sigma2 * np.linalg.inv(jacobian.T @ jacobian)
            stderr[seen] = np.sqrt(np.maximum(np.diag(covariance), 0.0))
        except np.linalg.LinAlgError:
            stderr[0] = np.inf  # a singular fit: no payload can be claimed
    else:
        stderr[0] = np.inf  # the mass moves no torque: the motion cannot tell a payload
        theta[1:] = 0.0
    return PayloadFit(
        payload=_payload(theta),
        stderr=tuple(float(s) for s in stderr),
        residual_rms_nm=float(np.sqrt(np.mean(result.fun**2))),
        residual_rms_without_nm=float(np.sqrt(np.mean(without**2))),
        samples=int(sum(len(rows) for _, rows, _ in projection.fitted)),
        unidentifiable=tuple(name for name, known in zip(PARAMETER_NAMES, seen, strict=True) if not known),
    )
