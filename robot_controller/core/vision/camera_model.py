"""A fixed pinhole camera looking from a position at a target: its intrinsics, its pose in OpenCV's convention
(x right, y down, z forward), the same pose as a MuJoCo camera (x right, y up, looking along -z), the projection of
world points to pixels, and the default camera that sees the whole workspace of any fixed-base arm."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from robot_controller.core.errors import ConfigError

MIN_IMAGE_PX = 16
#: When the viewing direction is this close to world ±z, world +y plays "up" (the cross product degenerates).
VERTICAL_COS = 0.999
#: The workspace sphere's radius over the half field of view it may fill: room for the markers' mounts.
WORKSPACE_MARGIN = 1.15
#: A diagonal, elevated view (from +x, -y, +z) for arms whose joint axes are not all parallel: every axis of a
#: Panda-like arm (vertical and horizontal) is then seen at an angle, so each joint moves its markers in the image.
DIAGONAL_VIEW = np.array([1.0, -1.0, 0.8])
#: Axes whose directions agree to this cosine count as parallel (a planar arm's).
PARALLEL_COS = 0.999


def _vector(value, key: str) -> np.ndarray:
    try:
        array = np.asarray(value, dtype=float).reshape(3)
    except (TypeError, ValueError):
        raise ConfigError(f"{key}: must be 3 numbers (m), got {value!r}") from None
    if not np.all(np.isfinite(array)):
        raise ConfigError(f"{key}: must be finite, got {array.tolist()}")
    return array


@dataclass(frozen=True)
class CameraModel:
    """:param position_m, target_m: world (m); :param fovy_deg: vertical field of view (MuJoCo's ``fovy``)."""

    position_m: np.ndarray
    target_m: np.ndarray
    width_px: int
    height_px: int
    fovy_deg: float = 45.0

    def __post_init__(self):
        object.__setattr__(self, "position_m", _vector(self.position_m, "camera_position_m"))
        object.__setattr__(self, "target_m", _vector(self.target_m, "camera_target_m"))
        if np.linalg.norm(self.target_m - self.position_m) < 1e-9:
            raise ConfigError("camera_target_m: must differ from camera_position_m")
        for key, value in (("image_width", self.width_px), ("image_height", self.height_px)):
            if not isinstance(value, int | np.integer) or value < MIN_IMAGE_PX:
                raise ConfigError(f"{key}: must be a whole number of pixels >= {MIN_IMAGE_PX}, got {value!r}")
        if not (np.isfinite(self.fovy_deg) and 1.0 <= self.fovy_deg <= 170.0):
            raise ConfigError(f"camera_fovy_deg: must be within [1, 170] degrees, got {self.fovy_deg}")

    @property
    def focal_px(self) -> float:
        """Focal length in pixels (square pixels): the vertical field of view spans the image height."""
        return 0.5 * self.height_px / np.tan(np.radians(self.fovy_deg) / 2)

    def intrinsics(self) -> np.ndarray:
        """K, (3, 3). The principal point is the image centre in OpenCV's pixel-centre coordinates, (w-1)/2:
        MuJoCo's frustum is symmetric about the optical axis and spans the image's outer edges."""
        f = self.focal_px
        return np.array([[f, 0.0, (self.width_px - 1) / 2], [0.0, f, (self.height_px - 1) / 2], [0.0, 0.0, 1.0]])

    def axes(self) -> np.ndarray:
        """The camera's right, down and forward directions in the world, the rows of (3, 3)."""
        forward = self.target_m - self.position_m
        forward /= np.linalg.norm(forward)
        up = np.array([0.0, 0.0, 1.0]) if abs(forward[2]) < VERTICAL_COS else np.array([0.0, 1.0, 0.0])
        right = np.cross(forward, up)
        right /= np.linalg.norm(right)
        down = np.cross(forward, right)
        return np.stack([right, down, forward])

    def world_to_camera(self) -> tuple[np.ndarray, np.ndarray]:
        """R (3, 3), t (3,): a world point p is R p + t in the camera frame (OpenCV's x right, y down, z forward)."""
        rotation = self.axes()
        return rotation, -rotation @ self.position_m

    def to_camera(self, points_world: np.ndarray) -> np.ndarray:
        rotation, translation = self.world_to_camera()
        return np.asarray(points_world, dtype=float).reshape(-1, 3) @ rotation.T + translation

    def project(self, points_world: np.ndarray) -> np.ndarray:
        """Pixels (k, 2) of world points (k, 3), u right and v down from the top-left pixel's centre."""
        camera = self.to_camera(points_world)
        with np.errstate(divide="ignore", invalid="ignore"):
            normalised = camera[:, :2] / camera[:, 2:3]
        k = self.intrinsics()
        return normalised * k[0, 0] + k[:2, 2]

    def in_view(self, points_world: np.ndarray) -> np.ndarray:
        """Whether each world point (k, 3) is in front of the camera and inside the image, (k,) bool."""
        depth_m = self.to_camera(points_world)[:, 2]
        pixels = self.project(points_world)
        inside = (pixels >= -0.5) & (pixels <= np.array([self.width_px, self.height_px]) - 0.5)
        return (depth_m > 1e-6) & inside.all(axis=1)

    def mujoco_quat(self) -> np.ndarray:
        """The camera's orientation for MuJoCo (w, x, y, z): its frame's columns are right, up and backward."""
        right, down, forward = self.axes()
        matrix = np.stack([right, -down, -forward], axis=1)
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, matrix.reshape(-1))
        return quat


def workspace_sphere(model: mujoco.MjModel) -> tuple[np.ndarray, float]:
    """Centre (m) and radius (m) of a sphere holding every pose of the arm: centred at the first joint's anchor,
    its radius the sum of the joint-to-joint distances plus the last link's extent beyond its joint (a bound
    that holds whatever the angles, since each link turns about its own joint)."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    anchors = data.xanchor[: model.njnt]
    radius = float(np.sum(np.linalg.norm(np.diff(anchors, axis=0), axis=1)))
    last_body = model.jnt_bodyid[model.njnt - 1]
    carried = [g for g in range(model.ngeom) if _descends(model, model.geom_bodyid[g], last_body)]
    extent = [np.linalg.norm(data.geom_xpos[g] - anchors[-1]) + model.geom_rbound[g] for g in carried]
    return anchors[0].copy(), radius + max(extent, default=0.0)


def _descends(model: mujoco.MjModel, body: int, ancestor: int) -> bool:
    while body > 0:
        if body == ancestor:
            return True
        body = model.body_parentid[body]
    return ancestor == 0


def viewing_direction(model: mujoco.MjModel) -> np.ndarray:
    """Unit vector from the workspace's centre to the camera: along the joints' common axis when every joint is a
    hinge about parallel axes (the motion is then in the image plane), else the diagonal view."""
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    axes = data.xaxis[: model.njnt]
    hinges = np.all(model.jnt_type[: model.njnt] == mujoco.mjtJoint.mjJNT_HINGE)
    if hinges and np.all(np.abs(axes @ axes[0]) > PARALLEL_COS):
        axis = axes[0] / np.linalg.norm(axes[0])
        # Seen from -y (else from +z, else from +x), as a drawing of the arm would show it.
        key = -axis[1] if abs(axis[1]) > 1e-6 else (axis[2] if abs(axis[2]) > 1e-6 else axis[0])
        return axis if key > 0 else -axis
    return DIAGONAL_VIEW / np.linalg.norm(DIAGONAL_VIEW)


def default_camera(model: mujoco.MjModel, width_px: int = 640, height_px: int = 480) -> CameraModel:
    """A fixed camera that holds the arm's workspace sphere inside the image with a margin, looking at its centre
    along :func:`viewing_direction`."""
    centre, radius = workspace_sphere(model)
    fovy_deg = 45.0
    half_vertical = np.radians(fovy_deg) / 2
    half_horizontal = np.arctan(np.tan(half_vertical) * width_px / height_px)
    # A sphere of radius r at distance d subtends a half-angle asin(r / d): fit it in the narrower half-angle.
    distance_m = WORKSPACE_MARGIN * radius / np.sin(min(half_vertical, half_horizontal))
    position = centre + distance_m * viewing_direction(model)
    return CameraModel(position, centre, int(width_px), int(height_px), fovy_deg)
