"""The arm as the camera sees it: the URDF's model with the markers as textured plates on their links, a light
and the camera, rendered offscreen by MuJoCo at given joint positions; markers hidden on demand (occlusion) and
the sensor's intensity noise."""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")  # offscreen, headless: before mujoco creates a context

import contextlib  # noqa: E402
from collections.abc import Iterable, Iterator  # noqa: E402
from pathlib import Path  # noqa: E402

import cv2  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

from robot_controller.core.errors import ConfigError  # noqa: E402
from robot_controller.core.vision.camera_model import CameraModel  # noqa: E402
from robot_controller.core.vision.markers import (  # noqa: E402
    ARUCO_DICTIONARY,
    MARKER_CELLS,
    QUIET_CELLS,
    MarkerLayout,
)

CAMERA_NAME = "vision_camera"
#: px per cell of a marker's texture: sharp edges once MuJoCo filters the texture down to the image.
TEXTURE_CELL_PX = 16
#: m, half the thickness of a marker's plate.
PLATE_HALF_THICKNESS_M = 0.0005
#: Geom groups: MuJoCo draws groups 0-2 by default and not 3-5, so moving a plate to HIDDEN_GROUP hides it.
SHOWN_GROUP, HIDDEN_GROUP = 2, 5


def marker_image(marker_id: int) -> np.ndarray:
    """The marker's picture with its white quiet zone, RGB uint8 (px, px, 3)."""
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, ARUCO_DICTIONARY))
    image = cv2.aruco.generateImageMarker(dictionary, marker_id, MARKER_CELLS * TEXTURE_CELL_PX, borderBits=1)
    quiet = QUIET_CELLS * TEXTURE_CELL_PX
    image = cv2.copyMakeBorder(image, quiet, quiet, quiet, quiet, cv2.BORDER_CONSTANT, value=255)
    return np.repeat(image[:, :, None], 3, axis=2)


def geom_name(marker_id: int) -> str:
    return f"vision_marker_{marker_id}"


def scene_spec(urdf_path: str | Path, layout: MarkerLayout, camera: CameraModel) -> mujoco.MjSpec:
    """The URDF's model with each marker a thin textured box on its body (no contact, its +z face the marker),
    a light beside the camera and the camera ``CAMERA_NAME``."""
    path = Path(urdf_path)
    if not path.is_file():
        raise ConfigError(f"urdf_path: no such file {str(path)!r}")
    spec = mujoco.MjSpec.from_file(str(path))
    for marker in layout.markers:
        body = spec.body(marker.body)
        if body is None:
            raise ConfigError(f"markers: marker {marker.marker_id} is on {marker.body!r}, no body of {path.name}")
        image = marker_image(marker.marker_id)
        texture = spec.add_texture(
            name=f"vision_texture_{marker.marker_id}",
            type=mujoco.mjtTexture.mjTEXTURE_2D,
            width=image.shape[1],
            height=image.shape[0],
            nchannel=3,
        )
        texture.data = image.tobytes()
        material = spec.add_material(name=f"vision_material_{marker.marker_id}", specular=0.0, shininess=0.0)
        material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = texture.name
        half_side_m = marker.size_m / 2 * (MARKER_CELLS + 2 * QUIET_CELLS) / MARKER_CELLS
        # The plate's outer face, not its middle, lies at the marker's position.
        centre = marker.position_m - marker.normal_in_body() * PLATE_HALF_THICKNESS_M
        body.add_geom(
            name=geom_name(marker.marker_id),
            type=mujoco.mjtGeom.mjGEOM_BOX,
            size=[half_side_m, half_side_m, PLATE_HALF_THICKNESS_M],
            pos=centre,
            quat=marker.quat,
            material=material.name,
            contype=0,
            conaffinity=0,
            group=SHOWN_GROUP,
            mass=0.0,
        )
    eye_m = camera.position_m
    spec.worldbody.add_light(pos=eye_m, dir=camera.target_m - eye_m, castshadow=False)
    spec.worldbody.add_camera(name=CAMERA_NAME, pos=eye_m, quat=camera.mujoco_quat(), fovy=camera.fovy_deg)
    return spec


@contextlib.contextmanager
def _gl_platform_of_environment() -> Iterator[None]:
    """MuJoCo picks its GL platform from MUJOCO_GL once, when first imported: a module imported before this one
    (the arm's model) may have fixed GLFW, which needs a display. Within this block, a renderer gets the EGL
    context MUJOCO_GL asks for; MuJoCo's choice is restored after (the renderer keeps its own context)."""
    from mujoco.rendering.classic import gl_context

    chosen = getattr(gl_context, "GLContext", None)
    if os.environ.get("MUJOCO_GL", "").lower() == "egl" and getattr(gl_context, "_MUJOCO_GL", "") != "egl":
        from mujoco.egl import GLContext

        gl_context.GLContext = GLContext
    try:
        yield
    finally:
        gl_context.GLContext = chosen


class Renderer:
    """Renders the arm, its markers seen by the camera, at joint positions (rad, m on a slide)."""

    def __init__(self, urdf_path: str | Path, layout: MarkerLayout, camera: CameraModel):
        self.layout, self.camera = layout, camera
        try:
            self.model = scene_spec(urdf_path, layout, camera).compile()
        except ValueError as exc:
            raise ConfigError(f"urdf_path: MuJoCo could not build the camera's scene: {exc}") from exc
        # The offscreen buffer must hold the image (MuJoCo's default is 640x480).
        self.model.vis.global_.offwidth = max(self.model.vis.global_.offwidth, camera.width_px)
        self.model.vis.global_.offheight = max(self.model.vis.global_.offheight, camera.height_px)
        self.data = mujoco.MjData(self.model)
        self._geoms = {m.marker_id: self.model.geom(geom_name(m.marker_id)).id for m in layout.markers}
        with _gl_platform_of_environment():
            self._renderer: mujoco.Renderer | None = mujoco.Renderer(self.model, camera.height_px, camera.width_px)

    @property
    def joint_count(self) -> int:
        return self.model.njnt

    def render(self, position: np.ndarray) -> np.ndarray:
        """The camera's image (height, width, 3) RGB uint8 of the arm at ``position``."""
        if self._renderer is None:
            raise RuntimeError("Renderer: render after close")
        position = np.asarray(position, dtype=float).reshape(-1)
        if position.shape != (self.model.njnt,):
            raise ValueError(f"position: {self.model.njnt} joint values expected, got {position.shape[0]}")
        self.data.qpos[: self.model.njnt] = position
        # Poses of the bodies, then of the camera and the light: all a picture needs, no dynamics.
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_comPos(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)
        self._renderer.update_scene(self.data, camera=CAMERA_NAME)
        return self._renderer.render()

    def hide(self, marker_ids: Iterable[int]) -> None:
        """Stop drawing these markers (an occlusion) until :meth:`show_all`."""
        for marker_id in marker_ids:
            if int(marker_id) in self._geoms:
                self.model.geom_group[self._geoms[int(marker_id)]] = HIDDEN_GROUP

    def show_all(self) -> None:
        for geom in self._geoms.values():
            self.model.geom_group[geom] = SHOWN_GROUP

    def close(self) -> None:
        # Explicitly: the renderer's destructor at interpreter exit prints an EGL traceback.
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def __enter__(self) -> Renderer:
        return self

    def __exit__(self, *_exc) -> None:
        self.close()


def add_pixel_noise(image: np.ndarray, std_px_intensity: float, rng: np.random.Generator) -> np.ndarray:
    """``image`` with independent Gaussian intensity noise (std in 0-255 levels) on every pixel and channel,
    rounded and clipped (in place on one float32 buffer: about 8 ms for a 640 × 480 colour frame, 3 ms mono)."""
    if not (np.isfinite(std_px_intensity) and std_px_intensity >= 0):
        raise ConfigError(f"pixel_noise_std: must be >= 0 intensity levels, got {std_px_intensity}")
    if std_px_intensity == 0:
        return image.copy()
    noisy = rng.standard_normal(image.shape, dtype=np.float32)
    noisy *= np.float32(std_px_intensity)
    noisy += image
    noisy += np.float32(0.5)  # rounds as the cast truncates
    np.clip(noisy, 0, 255, out=noisy)
    return noisy.astype(np.uint8)
