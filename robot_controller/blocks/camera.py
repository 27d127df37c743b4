"""The camera (the graph's ``camera_node``): it renders the arm as a fixed monochrome camera sees it (as marker
tracking uses: a third of the bytes, a third of the noise to draw), with fiducial markers on
every moving link, from the world's true state. Each frame is exposed at one of the world's states (every few of them:
``camera_rate_hz`` rounded to a whole number of the world's periods, so a run on the sim's clock repeats), noised, and
published ``latency_s`` after its exposure, stamped with it, beside its intrinsics (``CameraInfo``); the first frame
at once. Where the world waits, every state it hears is answered: by a frame, or by an empty image (no pixels, the
world's stamp), so the vision, and the controller after it, know no reading is to come for that tick and never wait
for one (which would stall the world)."""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

import cv2
import numpy as np

from robot_controller import resources
from robot_controller.blocks.block import Log
from robot_controller.blocks.values import CameraCalibration, CameraFrame, JointSample, check_joint_state
from robot_controller.core.errors import ConfigError
from robot_controller.core.model import load_model
from robot_controller.core.model.mujoco_model import joint_names
from robot_controller.core.vision.scene import add_pixel_noise
from robot_controller.parameters.builders import camera_model

#: An image with no pixels: where the world waits, "no frame at this state".
NO_PIXELS = np.zeros((0, 0), dtype=np.uint8)
# Stamps within this of a due time count as due (float ns rounding).
_EPS_S = 1e-6


class Darkroom:
    """Renders on a thread of its own (which holds the GL context), so a frame is made while its latency passes and
    the world's next ticks go on (MuJoCo lets go of the GIL while it renders); a frame is waited for only when it is
    due out."""

    def __init__(self, urdf: Any, layout: Any, camera: Any, joint_count: int, rng: np.random.Generator) -> None:
        self._local = threading.local()
        self.rng = rng  # drawn from on its thread alone, frame after frame: a run repeats
        self._thread = ThreadPoolExecutor(1, thread_name_prefix="camera_render")
        self._thread.submit(self._open, urdf, layout, camera).result()
        self._thread.submit(self._render, np.zeros(joint_count), [], 0.0).result()  # GL's set-up: not at a tick

    def _open(self, urdf: Any, layout: Any, camera: Any) -> None:
        from robot_controller.core.vision.scene import Renderer

        self._local.renderer = Renderer(urdf, layout, camera)

    def render(self, position: np.ndarray, hidden: list[int], noise_std: float) -> Future:
        """The arm at ``position`` with the markers ``hidden`` hidden and pixel noise of ``noise_std`` levels, to come
        (RGB pixels)."""
        return self._thread.submit(self._render, np.array(position, dtype=float), list(hidden), noise_std)

    def _render(self, position: np.ndarray, hidden: list[int], noise_std: float) -> np.ndarray:
        renderer = self._local.renderer
        renderer.show_all()
        if hidden:
            renderer.hide(hidden)
        gray = cv2.cvtColor(renderer.render(position), cv2.COLOR_RGB2GRAY)
        return add_pixel_noise(gray, noise_std, self.rng) if noise_std > 0 else gray

    def close(self) -> None:
        self._thread.submit(lambda: self._local.renderer.close()).result()
        self._thread.shutdown()


def frame_ticks(rate_hz: float, world_period_s: float) -> int:
    """How many of the world's periods a frame takes: the rate asked for, rounded to a whole number of them."""
    return max(1, round(1.0 / (rate_hz * world_period_s)))


class Camera:
    inputs = ("true_state",)
    outputs = ("image", "camera_info")

    def __init__(self, params: Mapping[str, Any], log: Log, *, world_waits: bool = False) -> None:
        from robot_controller.core.vision.markers import place_markers

        self.log = log
        self.world_waits = world_waits
        self.exposed_s = 0.0
        seed = params["seed"]
        self.rng = np.random.default_rng(None if seed < 0 else seed)
        urdf = resources.resolve_urdf(params["urdf_path"])
        model = load_model(urdf)
        self.joint_names = joint_names(model)
        self.camera = camera_model(params, model)
        self.layout = place_markers(model, self.camera)
        self.check_params(params)
        self.params = dict(params)
        self.darkroom = Darkroom(urdf, self.layout, self.camera, len(self.joint_names), self.rng)
        self.world_period_s: float | None = None
        self.last_stamp_s: float | None = None
        self.next_frame_s: float | None = None
        self.pending: deque[tuple[float, Future]] = deque()  # exposed (stamp s, its render), waiting out the latency
        self.hidden = False
        self.frames = 0
        self.calibration_k = self.camera.intrinsics()
        where = ", ".join(f"{x:.2f}" for x in self.camera.position_m)
        looking = ", ".join(f"{x:.2f}" for x in self.camera.target_m)
        log.info(
            f"camera at {params['camera_rate_hz']:g} Hz (a whole number of the world's states), "
            f"{self.camera.width_px}×{self.camera.height_px} px from [{where}] m looking at [{looking}] m, "
            f"{len(self.layout.markers)} markers on {len(self.layout.bodies())} links, "
            f"{params['latency_s'] * 1e3:g} ms latency, pixel noise σ {params['pixel_noise_std']:g}"
        )

    def start(self) -> dict[str, Any]:
        return {}

    def wake_period_s(self) -> float | None:
        return None

    def check_params(self, params: Mapping[str, Any]) -> None:
        link = params["occluded_link"]
        if link and link not in self.layout.bodies():
            raise ConfigError(
                f"occluded_link: {link!r} carries no marker; the links with markers are {list(self.layout.bodies())}"
            )

    def set_params(self, params: Mapping[str, Any], changed: set[str]) -> None:
        self.params = dict(params)

    def close(self) -> None:
        self.darkroom.close()

    def occluded_ids(self, stamp_s: float) -> list[int]:
        """The markers hidden at ``stamp_s`` (the occluded link's, within its window)."""
        link, window = self.params["occluded_link"], self.params["occlusion_s"]
        if not link:
            return []
        if window is not None and len(window) == 2 and not (window[0] <= stamp_s < window[0] + window[1]):
            return []
        return [m.marker_id for m in self.layout.markers if m.body == link]

    def step(self, t_s: float, inputs: Mapping[str, Any]) -> dict[str, Any]:
        state: JointSample | None = inputs.get("true_state")
        if state is None:
            return {}
        stamp_s = state.stamp_s
        if self.last_stamp_s is not None and stamp_s > self.last_stamp_s and self.world_period_s is None:
            self.world_period_s = stamp_s - self.last_stamp_s
        self.last_stamp_s = stamp_s
        first = self.frames == 0
        if self.next_frame_s is None and self.world_period_s is not None and not first:
            self.next_frame_s = self.exposed_s + self.frame_period_s()  # the frames keep to the world's states
        if first or (self.next_frame_s is not None and stamp_s >= self.next_frame_s - _EPS_S):
            checked = check_joint_state(state.names, state.position, state.velocity, self.joint_names)
            if isinstance(checked, str):
                self.log.warn("true_state", f"true state unusable: {checked}")
                return {}
            self.expose(stamp_s, checked[0])
        latency_s = 0.0 if first else self.params["latency_s"]
        if self.pending and stamp_s >= self.pending[0][0] + latency_s - _EPS_S:
            exposed_s, render = self.pending.popleft()
            frame = CameraFrame(exposed_s, render.result())
            info = CameraCalibration(frame.stamp_s, self.camera.width_px, self.camera.height_px, self.calibration_k)
            return {"image": frame, "camera_info": info}
        if self.world_waits:
            return {"image": CameraFrame(stamp_s, NO_PIXELS)}
        return {}

    def expose(self, stamp_s: float, position: np.ndarray) -> None:
        hidden = self.occluded_ids(stamp_s)
        if bool(hidden) != self.hidden:
            self.hidden = bool(hidden)
            what = f"{self.params['occluded_link']}'s markers"
            self.log.info(f"camera: {what} {'hidden' if hidden else 'in view again'} at {stamp_s:.2f} s")
        self.pending.append((stamp_s, self.darkroom.render(position, hidden, self.params["pixel_noise_std"])))
        self.frames += 1
        self.exposed_s = stamp_s
        self.next_frame_s = None if self.world_period_s is None else stamp_s + self.frame_period_s()

    def frame_period_s(self) -> float:
        """The period of the frames, s: the rate asked for, as a whole number of the world's periods."""
        rate_hz = self.params["camera_rate_hz"]
        if self.world_period_s is None:
            return 1.0 / rate_hz
        return frame_ticks(rate_hz, self.world_period_s) * self.world_period_s
