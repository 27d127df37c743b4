"""ArUco markers fixed to the arm's links: where each one is on its link (the layout the solver believes), a
calibration error of that layout, and a deterministic placement that a given camera sees on every moving link."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import mujoco
import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.vision.camera_model import CameraModel

#: The cv2.aruco dictionary (attribute name): 4x4 bits, 250 ids, the largest Hamming distance for few markers.
ARUCO_DICTIONARY = "DICT_4X4_250"
#: Cells across a marker's image: 4 data bits and one black border cell each side.
MARKER_CELLS = 6
#: White cells around the black square: the quiet zone the detector needs to find its outline.
QUIET_CELLS = 1
#: px, a marker's side in the image at the camera's distance to the workspace's centre: enough cells (~4 px each)
#: for the detector at an oblique view.
MARKER_SIDE_PX = 26.0
#: The mount's length over the cube's side: the cube clears the link's own shape so the mesh does not hide it;
#: the longer ones where the short one would crowd another link's cube.
MOUNT_GAPS = (0.3, 1.0, 2.0)
#: The last link's longer mounts: its cubes alone constrain its joint, out of the wrist's crowd of cubes.
LAST_MOUNT_GAPS = (1.5, 2.5)
#: Least distance between two cubes' centres over the side: apart whatever their orientations (diagonal √3).
CLEARANCE = 1.8
#: Directions tried for a mount, about the joint's axis.
MOUNT_DIRECTIONS = 8
#: Mount directions whose facing the camera differs by less than this count as equal (the longer lever wins).
FACING_TIE = 0.1


def quat_to_matrix(quat: np.ndarray) -> np.ndarray:
    matrix = np.zeros(9)
    mujoco.mju_quat2Mat(matrix, np.asarray(quat, dtype=float) / np.linalg.norm(quat))
    return matrix.reshape(3, 3)


def matrix_to_quat(matrix: np.ndarray) -> np.ndarray:
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(matrix, dtype=float).reshape(-1))
    return quat


@dataclass(frozen=True, eq=False)
class Marker:
    """A square marker on link ``body``: its centre ``position_m`` and orientation ``quat`` (w, x, y, z) in the
    body's frame, its normal the local +z; ``size_m`` the black square's side (the quiet zone is around it)."""

    marker_id: int
    body: str
    position_m: np.ndarray
    quat: np.ndarray
    size_m: float

    def __post_init__(self):
        object.__setattr__(self, "position_m", np.asarray(self.position_m, dtype=float).reshape(3))
        object.__setattr__(self, "quat", np.asarray(self.quat, dtype=float).reshape(4))
        if not np.all(np.isfinite(self.position_m)) or not np.all(np.isfinite(self.quat)):
            raise ConfigError(f"markers: marker {self.marker_id}'s position and quat must be finite")
        if not (np.isfinite(self.size_m) and self.size_m > 0):
            raise ConfigError(f"markers: marker {self.marker_id}'s size_m must be > 0, got {self.size_m}")

    def __eq__(self, other) -> bool:  # by value: the arrays compared element by element
        if not isinstance(other, Marker):
            return NotImplemented
        same = (self.marker_id, self.body, self.size_m) == (other.marker_id, other.body, other.size_m)
        return same and np.array_equal(self.position_m, other.position_m) and np.array_equal(self.quat, other.quat)

    __hash__ = None

    def rotation(self) -> np.ndarray:
        """The marker's axes in the body frame, columns x, y, normal."""
        return quat_to_matrix(self.quat)

    def corners_in_body(self) -> np.ndarray:
        """(4, 3) in the body frame, in the order cv2.aruco reports a detection's corners: the marker image's
        top-left, top-right, bottom-right, bottom-left. The texture's top row lies along local +y and its first
        column along local -x (as MuJoCo maps a 2D texture on a box's +z face; checked against detections)."""
        half = self.size_m / 2
        local = np.array([[-half, half, 0.0], [half, half, 0.0], [half, -half, 0.0], [-half, -half, 0.0]])
        return self.position_m + local @ self.rotation().T

    def normal_in_body(self) -> np.ndarray:
        return self.rotation()[:, 2]


@dataclass(frozen=True)
class MarkerLayout:
    markers: tuple[Marker, ...]

    def __post_init__(self):
        object.__setattr__(self, "markers", tuple(self.markers))
        ids = [m.marker_id for m in self.markers]
        if len(set(ids)) != len(ids):
            raise ConfigError(f"markers: ids must be distinct, got {sorted(ids)}")

    def bodies(self) -> tuple[str, ...]:
        """The bodies carrying markers, each once, in the layout's order."""
        return tuple(dict.fromkeys(m.body for m in self.markers))

    def ids(self) -> tuple[int, ...]:
        return tuple(m.marker_id for m in self.markers)

    def by_id(self) -> dict[int, Marker]:
        return {m.marker_id: m for m in self.markers}

    def on(self, body: str) -> tuple[int, ...]:
        """The ids of the markers on ``body``."""
        return tuple(m.marker_id for m in self.markers if m.body == body)

    def with_error(self, position_std_m: float, angle_std_rad: float, rng: np.random.Generator) -> MarkerLayout:
        """The layout as a calibration would measure it: each marker moved by a Gaussian offset (m, per axis) and
        turned about a Gaussian rotation vector (rad, per axis) in its body's frame."""
        moved = []
        for marker in self.markers:
            offset_m = rng.normal(0.0, position_std_m, 3)
            turn = np.zeros(4)
            mujoco.mju_axisAngle2Quat(turn, *_axis_angle(rng.normal(0.0, angle_std_rad, 3)))
            quat = np.zeros(4)
            mujoco.mju_mulQuat(quat, turn, marker.quat)
            moved.append(Marker(marker.marker_id, marker.body, marker.position_m + offset_m, quat, marker.size_m))
        return MarkerLayout(tuple(moved))

    def without(self, marker_ids: Iterable[int]) -> MarkerLayout:
        dropped = set(int(i) for i in marker_ids)
        return MarkerLayout(tuple(m for m in self.markers if m.marker_id not in dropped))


def _axis_angle(rotation_vector: np.ndarray) -> tuple[np.ndarray, float]:
    angle_rad = float(np.linalg.norm(rotation_vector))
    if angle_rad < 1e-12:
        return np.array([1.0, 0.0, 0.0]), 0.0
    return rotation_vector / angle_rad, angle_rad


def reference_pose(model: mujoco.MjModel) -> np.ndarray:
    """Mid-range on a limited joint, else 0: the pose the mounts are chosen to face the camera in."""
    n = model.njnt
    limited = model.jnt_limited[:n].astype(bool)
    return np.where(limited, model.jnt_range[:n].mean(axis=1), 0.0)


def moving_bodies(model: mujoco.MjModel) -> list[int]:
    """The bodies a joint moves directly (one per joint on a serial chain), in the joints' order."""
    return list(dict.fromkeys(int(b) for b in model.jnt_bodyid[: model.njnt]))


def rigid_group(model: mujoco.MjModel, body: int) -> list[int]:
    """``body`` and its descendants welded to it (reached without crossing a joint): one rigid link."""
    group = [body]
    for child in range(body + 1, model.nbody):
        if model.body_parentid[child] in group and model.body_jntnum[child] == 0:
            group.append(child)
    return group


def _link_points(model: mujoco.MjModel, data: mujoco.MjData, body: int) -> np.ndarray:
    """Corners of the bounding boxes of the link's geoms, in ``body``'s frame, (k, 3)."""
    group = rigid_group(model, body)
    rotation, origin = data.xmat[body].reshape(3, 3), data.xpos[body]
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], dtype=float)
    points = []
    for geom in np.flatnonzero(np.isin(model.geom_bodyid, group)):
        centre, half = model.geom_aabb[geom, :3], model.geom_aabb[geom, 3:]
        local = centre + signs * half
        world = data.geom_xpos[geom] + local @ data.geom_xmat[geom].reshape(3, 3).T
        points.append((world - origin) @ rotation)
    return np.concatenate(points) if points else np.zeros((0, 3))


def marker_size_m(camera: CameraModel) -> float:
    """The black square's side (m) that spans ``MARKER_SIDE_PX`` at the camera's distance to its target."""
    distance_m = float(np.linalg.norm(camera.target_m - camera.position_m))
    return MARKER_SIDE_PX * distance_m / camera.focal_px


def _perpendicular_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors spanning the plane normal to ``axis``, the first along the body axis most normal to it."""
    unit = np.eye(3)[int(np.argmin(np.abs(axis)))]
    first = unit - axis * (unit @ axis)
    first /= np.linalg.norm(first)
    return first, np.cross(axis, first)


def _mount(model, data, joint: int, toward: np.ndarray, cube_m: float, taken: list[np.ndarray], gaps=MOUNT_GAPS):
    """The cube's centre and its outward direction in the body's frame: out from the link's shape, normal to its
    joint's axis (so the joint moves it), clear of the cubes already placed (``taken``, world, in the reference
    pose), the direction nearest ``toward`` (world; ties to the longer lever about the axis); a longer mount
    where every direction is crowded."""
    body = model.jnt_bodyid[joint]
    axis = model.jnt_axis[joint] / np.linalg.norm(model.jnt_axis[joint])
    points = _link_points(model, data, body)
    base = 0.5 * (points.min(axis=0) + points.max(axis=0)) if len(points) else model.jnt_pos[joint].copy()
    first, second = _perpendicular_basis(axis)
    rotation, origin = data.xmat[body].reshape(3, 3), data.xpos[body]
    best = None
    for gap in gaps:
        for k in range(MOUNT_DIRECTIONS):
            angle_rad = 2 * np.pi * k / MOUNT_DIRECTIONS
            out = np.cos(angle_rad) * first + np.sin(angle_rad) * second
            support_m = max(float(np.max((points - base) @ out)) if len(points) else 0.0, 0.0)
            centre = base + out * (support_m + (gap + 0.5) * cube_m)
            world = origin + rotation @ centre
            clear = all(np.linalg.norm(world - other) >= CLEARANCE * cube_m for other in taken)
            facing = float((rotation @ out) @ toward)
            radial = centre - model.jnt_pos[joint]
            lever_m = float(np.linalg.norm(radial - axis * (radial @ axis)))
            key = (clear, round(facing / FACING_TIE), lever_m)
            if best is None or key > best[0]:
                best = (key, centre, out, world)
        if best[0][0]:
            break
    taken.append(best[3])
    return best[1], best[2]


def _mount_directions(model, data, body: int, camera: CameraModel) -> list[np.ndarray]:
    """Where each of the link's cubes should point (world): to the camera, along its optical axis rather than to
    the link (perspective would break the ties of a view along the joint's axis, which the lever must decide).
    The last moving link gets a second cube on the far side: its joint is constrained by its markers alone, and
    turning it may hide the first cube behind the link."""
    to_camera = -camera.axes()[2]
    if body != moving_bodies(model)[-1]:
        return [to_camera]
    return [to_camera, None]


def _cube_faces(centre: np.ndarray, out: np.ndarray, axis: np.ndarray, cube_m: float) -> list[np.ndarray]:
    """The six faces of a cube about ``centre``: each a rotation (columns x, y, normal) and its centre."""
    third = np.cross(out, axis)
    faces = []
    for normal, along in ((out, axis), (axis, third), (-axis, third), (third, out), (-third, out), (-out, axis)):
        x = along - normal * (along @ normal)
        x /= np.linalg.norm(x)
        faces.append((np.stack([x, np.cross(normal, x), normal], axis=1), centre + normal * cube_m / 2))
    return faces


def place_markers(model: mujoco.MjModel, camera: CameraModel) -> MarkerLayout:
    """A cube of six markers (distinct ids, counted from 0) on each moving link, on a short mount out of the
    link's shape towards the camera, sized for ``MARKER_SIDE_PX``: whichever way the joints turn, some face of
    it faces the camera. Deterministic."""
    data = mujoco.MjData(model)
    data.qpos[: model.njnt] = reference_pose(model)
    mujoco.mj_kinematics(model, data)
    size_m = marker_size_m(camera)
    cube_m = size_m * (MARKER_CELLS + 2 * QUIET_CELLS) / MARKER_CELLS
    markers: list[Marker] = []
    taken: list[np.ndarray] = []
    for body in moving_bodies(model):
        joint = int(np.flatnonzero(model.jnt_bodyid[: model.njnt] == body)[-1])
        axis = model.jnt_axis[joint] / np.linalg.norm(model.jnt_axis[joint])
        first_out = None
        for toward in _mount_directions(model, data, body, camera):
            if toward is None:  # opposite the first cube
                toward = -data.xmat[body].reshape(3, 3) @ first_out
            last = body == moving_bodies(model)[-1]
            centre, out = _mount(model, data, joint, toward, cube_m, taken, LAST_MOUNT_GAPS if last else MOUNT_GAPS)
            first_out = out if first_out is None else first_out
            for rotation, position in _cube_faces(centre, out, axis, cube_m):
                quat = matrix_to_quat(rotation)
                markers.append(Marker(len(markers), model.body(body).name, position, quat, size_m))
    return MarkerLayout(tuple(markers))
