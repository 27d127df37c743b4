"""The markers' corners through the kinematic chain: where each corner is in the world at given joint positions,
where the camera sees it (px), and how those pixels move with each joint (the analytic Jacobian, from the
joints' world axes and anchors: a hinge moves a point by axis x (point - anchor), a slide by its axis)."""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.vision.camera_model import CameraModel
from robot_controller.core.vision.markers import MarkerLayout

#: m, least depth a corner is projected at: a wild iterate behind the camera must not divide by zero.
MIN_DEPTH_M = 1e-3


def moved_by(model: mujoco.MjModel) -> np.ndarray:
    """(joints, bodies) bool: whether joint j moves body b (b is j's body or descends from it)."""
    moves = np.zeros((model.njnt, model.nbody), dtype=bool)
    for joint in range(model.njnt):
        for body in range(model.nbody):
            ancestor = body
            while ancestor > 0 and ancestor != model.jnt_bodyid[joint]:
                ancestor = model.body_parentid[ancestor]
            moves[joint, body] = ancestor == model.jnt_bodyid[joint] and ancestor > 0
    return moves


class MarkerChain:
    """The corners of a layout's markers on ``model``'s bodies, seen by ``camera``."""

    def __init__(self, model: mujoco.MjModel, layout: MarkerLayout, camera: CameraModel):
        self.model, self.layout, self.camera = model, layout, camera
        self.data = mujoco.MjData(model)
        self.joint_count = model.njnt
        self._body: dict[int, int] = {}
        self._corners: dict[int, np.ndarray] = {}
        self._normal: dict[int, np.ndarray] = {}
        for marker in layout.markers:
            body = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, marker.body)
            if body < 0:
                raise ConfigError(f"markers: marker {marker.marker_id} is on {marker.body!r}, no body of the arm")
            self._body[marker.marker_id] = body
            self._corners[marker.marker_id] = marker.corners_in_body()
            self._normal[marker.marker_id] = marker.normal_in_body()
        self._moves = moved_by(model)
        self._slide = model.jnt_type[: model.njnt] == mujoco.mjtJoint.mjJNT_SLIDE
        self._rotation, self._translation = camera.world_to_camera()
        self._focal_px = camera.focal_px
        self._centre_px = camera.intrinsics()[:2, 2]

    def ids(self) -> tuple[int, ...]:
        return tuple(self._body)

    def pose(self, position: np.ndarray) -> None:
        """Place the bodies at joint ``position`` (rad, m on a slide)."""
        self.data.qpos[: self.joint_count] = position
        mujoco.mj_kinematics(self.model, self.data)

    def corners_world(self, marker_ids: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """World corners (4k, 3) of the markers, in the pose last set, and each corner's body (4k,)."""
        bodies = np.repeat([self._body[i] for i in marker_ids], 4)
        local = np.concatenate([self._corners[i] for i in marker_ids])
        rotations = self.data.xmat[bodies].reshape(-1, 3, 3)
        return self.data.xpos[bodies] + np.einsum("kij,kj->ki", rotations, local), bodies

    def normals_world(self, marker_ids: Sequence[int]) -> np.ndarray:
        bodies = [self._body[i] for i in marker_ids]
        rotations = self.data.xmat[bodies].reshape(-1, 3, 3)
        return np.einsum("kij,kj->ki", rotations, np.array([self._normal[i] for i in marker_ids]))

    def project(self, marker_ids: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (4k, 2) of the markers' corners and their Jacobian (4k, 2, joints) px per rad (or m)."""
        points, bodies = self.corners_world(marker_ids)
        camera = points @ self._rotation.T + self._translation
        depth = np.maximum(camera[:, 2], MIN_DEPTH_M)
        pixels = self._focal_px * camera[:, :2] / depth[:, None] + self._centre_px
        # d(pixel)/d(camera point): the pinhole's derivative, (4k, 2, 3).
        dproj = np.zeros((len(points), 2, 3))
        dproj[:, 0, 0] = dproj[:, 1, 1] = self._focal_px / depth
        dproj[:, :, 2] = -self._focal_px * camera[:, :2] / depth[:, None] ** 2
        # d(world point)/d(joint), (joints, 4k, 3): zero where the joint does not carry the corner's body.
        axes = self.data.xaxis[: self.joint_count]
        anchors = self.data.xanchor[: self.joint_count]
        velocity = np.cross(axes[:, None, :], points[None, :, :] - anchors[:, None, :])
        velocity[self._slide] = axes[self._slide][:, None, :]
        velocity *= self._moves[:, bodies][:, :, None]
        jacobian = np.einsum("kab,bc,jkc->kaj", dproj, self._rotation, velocity)
        return pixels, jacobian

    def facing(self, marker_ids: Sequence[int]) -> np.ndarray:
        """Cosine between each marker's normal and the ray from the camera to its centre (< 0: facing it)."""
        points, _ = self.corners_world(marker_ids)
        centres = points.reshape(-1, 4, 3).mean(axis=1)
        rays = centres - self.camera.position_m
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
        return np.einsum("ki,ki->k", self.normals_world(marker_ids), rays)


def joint_correlation(jacobian: np.ndarray, rank_tolerance: float = 1e-9) -> np.ndarray:
    """The correlation of the joints' errors, from the Gauss-Newton covariance (JᵀJ)⁺ on the directions the pixels
    see (joints, joints; 0 off the diagonal for a joint they do not): joints whose axes are nearly parallel err
    together, which a filter told only each joint's σ takes for motion."""
    information = jacobian.T @ jacobian
    eigenvalues, vectors = np.linalg.eigh(information)
    n = jacobian.shape[1]
    if eigenvalues[-1] <= 0:
        return np.eye(n)
    seen = eigenvalues > rank_tolerance * eigenvalues[-1]
    covariance = (vectors[:, seen] / eigenvalues[seen]) @ vectors[:, seen].T
    blind = np.any(np.abs(vectors[:, ~seen]) > 1e-6, axis=1)
    scale = np.sqrt(np.where(blind, 1.0, np.diagonal(covariance)))
    correlation = covariance / np.outer(scale, scale)
    correlation[blind, :] = 0.0
    correlation[:, blind] = 0.0
    np.fill_diagonal(correlation, 1.0)
    return np.clip(correlation, -1.0, 1.0)


def joint_std(jacobian: np.ndarray, pixel_std_px: float, rank_tolerance: float = 1e-9) -> np.ndarray:
    """Per-joint standard deviation from the Gauss-Newton covariance pixel_std² (JᵀJ)⁻¹, J (rows, joints): a
    joint with a part in a direction the pixels do not see (an eigenvalue under the tolerance) gets inf."""
    information = jacobian.T @ jacobian
    eigenvalues, vectors = np.linalg.eigh(information)
    if eigenvalues[-1] <= 0:
        return np.full(jacobian.shape[1], np.inf)
    seen = eigenvalues > rank_tolerance * eigenvalues[-1]
    variance = (vectors[:, seen] ** 2) @ (1.0 / eigenvalues[seen])
    blind = np.any(np.abs(vectors[:, ~seen]) > 1e-6, axis=1)
    return np.where(blind, np.inf, pixel_std_px * np.sqrt(variance))
