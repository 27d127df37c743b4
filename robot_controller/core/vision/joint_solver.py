"""Every joint angle at once from the markers' corners in one image: nonlinear least squares of the corners'
reprojection error over the kinematic chain (Gauss-Newton with Levenberg damping and the analytic Jacobian),
from the last solution, within the joint limits; markers that do not fit dropped; per-joint uncertainty from
the Gauss-Newton covariance. And which joints a camera can observe at all, checked before a run."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.model.mujoco_model import load_model, position_ranges
from robot_controller.core.vision.camera_model import CameraModel
from robot_controller.core.vision.marker_kinematics import MarkerChain, joint_correlation, joint_std
from robot_controller.core.vision.markers import MarkerLayout

#: px, a marker whose corners' RMS residual exceeds this after a solve is an outlier (a misdetection, a marker
#: moved on its link): dropped, and the solve redone without it.
OUTLIER_PX = 5.0
MAX_ITERATIONS = 30
#: rad (m): a step this small has converged (a hundredth of the precision sought).
STEP_TOLERANCE = 1e-7
#: Levenberg damping, relative to the information matrix's diagonal: keeps a step from a far guess bounded.
INITIAL_DAMPING = 1e-4
#: Of a marker's normal with the ray to it: a marker seen more edge-on than this is not counted as visible.
FACING_COS = -0.2


@dataclass(frozen=True)
class JointSolution:
    """``position`` rad (m on a slide) per joint; ``std`` its standard deviation, inf for a joint no detected
    marker constrains; ``residual_px`` the RMS reprojection error of the corners used; ``markers_used`` their
    markers' ids."""

    position: np.ndarray
    std: np.ndarray
    residual_px: float
    markers_used: tuple[int, ...]
    #: (joints, joints) the correlation of the joints' errors (identity where unknown)
    correlation: np.ndarray | None = None


class JointSolver:
    """Joint positions from detected marker corners, for the arm of ``urdf_path`` seen by ``camera``.

    :param pixel_std_px: the corners' detection noise (px), the scale of the reported ``std``."""

    def __init__(self, urdf_path: str | Path, layout: MarkerLayout, camera: CameraModel, pixel_std_px: float = 0.5):
        if not (np.isfinite(pixel_std_px) and pixel_std_px > 0):
            raise ConfigError(f"pixel_std_px: must be > 0, got {pixel_std_px}")
        self.model = load_model(urdf_path)
        self.chain = MarkerChain(self.model, layout, camera)
        self.pixel_std_px = float(pixel_std_px)
        ranges = position_ranges(self.model)
        self.lower, self.upper = ranges[:, 0], ranges[:, 1]

    @property
    def joint_count(self) -> int:
        return self.chain.joint_count

    def solve(self, detections: dict[int, np.ndarray], guess: np.ndarray) -> JointSolution | None:
        """The joint positions that best explain ``detections`` (id -> (4, 2) px corners, cv2's order), from
        ``guess`` (the last solution); None when no marker of the layout was detected."""
        guess = np.asarray(guess, dtype=float).reshape(-1)
        if guess.shape != (self.joint_count,):
            raise ValueError(f"guess: {self.joint_count} joint values expected, got {guess.shape[0]}")
        known = set(self.chain.ids())
        used = [i for i in sorted(detections) if i in known]
        position = np.clip(guess, self.lower, self.upper)
        while used:
            observed = np.concatenate([np.asarray(detections[i], dtype=float).reshape(4, 2) for i in used])
            position = self._least_squares(used, observed, position)
            residual = self._residual(used, observed, position)
            per_marker_px = np.sqrt(np.mean(residual.reshape(len(used), 8) ** 2, axis=1))
            worst = int(np.argmax(per_marker_px))
            if per_marker_px[worst] <= OUTLIER_PX:
                break
            # One at a time: one bad marker drags the fit, and with it the others' residuals.
            used.pop(worst)
        if not used:
            return None
        _, jacobian = self.chain.project(used)  # at the solution: _residual posed it
        rows = jacobian.reshape(-1, self.joint_count)
        std = joint_std(rows, self.pixel_std_px)
        rms_px = float(np.sqrt(np.mean(residual**2)))
        return JointSolution(position, std, rms_px, tuple(used), joint_correlation(rows))

    def _residual(self, used: list[int], observed: np.ndarray, position: np.ndarray) -> np.ndarray:
        self.chain.pose(position)
        pixels, _ = self.chain.project(used)
        return (pixels - observed).reshape(-1)

    def _least_squares(self, used: list[int], observed: np.ndarray, position: np.ndarray) -> np.ndarray:
        """Levenberg-Marquardt on the corners' pixel error, each step clipped into the joint limits."""
        damping = INITIAL_DAMPING
        self.chain.pose(position)
        pixels, jacobian = self.chain.project(used)
        residual = (pixels - observed).reshape(-1)
        cost = residual @ residual
        for _ in range(MAX_ITERATIONS):
            j = jacobian.reshape(-1, self.joint_count)
            information, gradient = j.T @ j, j.T @ residual
            # Damping on the diagonal and a floor: a joint no marker sees has a zero column (and no step).
            scale = np.diag(information) + 1e-9 * (np.max(np.diag(information)) + 1.0)
            step = -np.linalg.solve(information + damping * np.diag(scale), gradient)
            candidate = np.clip(position + step, self.lower, self.upper)
            self.chain.pose(candidate)
            pixels, candidate_jacobian = self.chain.project(used)
            candidate_residual = (pixels - observed).reshape(-1)
            candidate_cost = candidate_residual @ candidate_residual
            if candidate_cost <= cost:
                moved = np.max(np.abs(candidate - position))
                position, residual, jacobian, cost = candidate, candidate_residual, candidate_jacobian, candidate_cost
                damping = max(damping / 10, 1e-9)
                if moved < STEP_TOLERANCE:
                    break
            else:
                damping *= 10
                if damping > 1e6:
                    break
        return position


def visible_markers(chain: MarkerChain, position: np.ndarray) -> tuple[int, ...]:
    """The markers ``chain``'s camera sees at joint ``position``: every corner in front of it and inside the
    image, the face turned to it (normal against the ray by more than ``FACING_COS``). Other links' occlusion
    is not modelled."""
    chain.pose(np.asarray(position, dtype=float))
    ids = list(chain.ids())
    if not ids:
        return ()
    corners, _ = chain.corners_world(ids)
    inside = chain.camera.in_view(corners).reshape(-1, 4).all(axis=1)
    facing = chain.facing(ids) < FACING_COS
    return tuple(i for i, ok in zip(ids, inside & facing, strict=True) if ok)


def observable_joints(
    urdf_path_or_model: str | Path | mujoco.MjModel,
    layout: MarkerLayout,
    camera: CameraModel,
    positions: np.ndarray,
    max_std_rad: float = 0.05,
) -> np.ndarray:
    """(joints,) bool: whether the markers the camera sees constrain each joint at every one of ``positions``
    (poses, joints): its std at a pixel's noise within ``max_std_rad``."""
    model = urdf_path_or_model
    if not isinstance(model, mujoco.MjModel):
        model = load_model(model)
    chain = MarkerChain(model, layout, camera)
    positions = np.atleast_2d(np.asarray(positions, dtype=float))
    if positions.shape[1] != model.njnt:
        raise ValueError(f"positions: {model.njnt} joint values a pose expected, got {positions.shape[1]}")
    observable = np.ones(model.njnt, dtype=bool)
    for position in positions:
        seen = visible_markers(chain, position)
        if not seen:
            return np.zeros(model.njnt, dtype=bool)
        _, jacobian = chain.project(list(seen))
        observable &= joint_std(jacobian.reshape(-1, model.njnt), 1.0) <= max_std_rad
    return observable


def unobservable_reason(model: mujoco.MjModel, observable: np.ndarray) -> str:
    """One line naming the joints the camera cannot observe, or "" if it observes all."""
    names = [model.joint(j).name for j in np.flatnonzero(~np.asarray(observable))]
    return f"the camera cannot observe joint(s) {', '.join(names)}: no marker it sees moves with them" if names else ""
