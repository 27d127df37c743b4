"""The vision: the markers found in each camera frame, the arm's joints solved from them together over its chain, a
reading per frame stamped with the frame's exposure, each joint with its σ (``inf`` where no marker seen constrains
it: the controller runs that joint on its model). As ``sensor_node``'s block (``--sensing camera``) the readings are
the loop's; as ``vision_node``'s (``--sensing both``) they go beside the encoder's, to be fused by the controller's
filter. A frame with no marker found is still a reading (every σ ``inf``): the controller counts on one per frame."""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import numpy as np

from robot_controller import resources
from robot_controller.blocks.block import Log
from robot_controller.blocks.values import CameraFrame, CompressedFrame, JointSample
from robot_controller.core.model import load_model
from robot_controller.core.model.mujoco_model import joint_names, position_ranges
from robot_controller.parameters.builders import camera_model

#: JPEG quality of the detections' image (the bag keeps a 640 × 480 one in about 30 kB)
JPEG_QUALITY = 80


class Vision:
    inputs = ("image",)
    outputs = ("reading", "detections")
    #: the port its readings leave by
    reading_port = "reading"
    #: where the world waits, answer a tick with no frame with the last reading again: the loop's sensor, whose
    #: reading each tick waits for
    repeats = True

    def __init__(self, params: Mapping[str, Any], log: Log, *, world_waits: bool = False) -> None:
        from robot_controller.core.vision.detection import MarkerDetector
        from robot_controller.core.vision.joint_solver import JointSolver
        from robot_controller.core.vision.markers import place_markers

        self.log = log
        self.world_waits = world_waits
        seed = params["seed"]
        rng = np.random.default_rng(None if seed < 0 else seed)
        urdf = resources.resolve_urdf(params["urdf_path"])
        model = load_model(urdf)
        self.joint_names = joint_names(model)
        self.camera = camera_model(params, model)
        layout = place_markers(model, self.camera)
        error_m, error_rad = params["marker_calibration_error_m"], params["marker_calibration_error_rad"]
        if error_m > 0 or error_rad > 0:
            layout = layout.with_error(error_m, error_rad, rng)
        self.detector = MarkerDetector()
        self.solver = JointSolver(urdf, layout, self.camera, params["corner_std_px"])
        ranges = position_ranges(model)
        self.guess = np.clip(np.zeros(len(self.joint_names)), ranges[:, 0], ranges[:, 1])
        self.last: JointSample | None = None
        self.params = dict(params)
        self.next_detections_s = -np.inf
        self.frames = 0
        self.solved = 0
        self.cost_s = 0.0
        self.unseen: tuple[str, ...] = ()
        log.info(
            f"vision: {len(layout.markers)} markers on {len(layout.bodies())} links, the joints solved together "
            f"from their corners (σ {params['corner_std_px']:g} px)"
            + (f", calibration error σ {error_m * 1e3:g} mm, {error_rad * 1e3:g} mrad" if error_m or error_rad else "")
        )

    def start(self) -> dict[str, Any]:
        return {}

    def wake_period_s(self) -> float | None:
        return None

    def check_params(self, params: Mapping[str, Any]) -> None:
        pass

    def set_params(self, params: Mapping[str, Any], changed: set[str]) -> None:
        self.params = dict(params)
        self.solver.pixel_std_px = params["corner_std_px"]

    def step(self, t_s: float, inputs: Mapping[str, Any]) -> dict[str, Any]:
        frame: CameraFrame | str | None = inputs.get("image")
        if frame is None:
            return {}
        if isinstance(frame, str):
            self.log.warn("image", f"image dropped: {frame}")
            return {}
        if frame.pixels.size == 0:  # no frame at this tick: the last reading again (it adds nothing to the filter)
            return {self.reading_port: self.last} if self.repeats and self.world_waits and self.last is not None else {}
        started = time.perf_counter()
        detections = self.detector.detect(frame.pixels)
        solution = self.solver.solve(detections, self.guess) if detections else None
        if solution is not None and self.solved == 0:  # the first from afar: once more from where it got to
            solution = self.solver.solve(detections, solution.position) or solution
        n = len(self.joint_names)
        correlation = None
        if solution is None:
            position, position_std = self.guess, np.full(n, np.inf)
        else:
            position, position_std, correlation = solution.position, solution.std, solution.correlation
            self.guess = position
            self.solved += 1
        self.frames += 1
        self.cost_s += time.perf_counter() - started
        self.say_unseen(position_std)
        self.last = JointSample(frame.stamp_s, self.joint_names, position, np.zeros(n), None, position_std, correlation)
        out: dict[str, Any] = {self.reading_port: self.last}
        rate_hz = self.params["detections_rate_hz"]
        if rate_hz > 0 and frame.stamp_s >= self.next_detections_s:
            self.next_detections_s = max(self.next_detections_s + 1.0 / rate_hz, frame.stamp_s)
            out["detections"] = CompressedFrame(frame.stamp_s, jpeg(self.detector.draw(frame.pixels, detections)))
        return out

    def say_unseen(self, position_std: np.ndarray) -> None:
        """Which joints no marker found constrains, said when that changes."""
        unseen = tuple(
            name for name, sigma in zip(self.joint_names, position_std.tolist(), strict=False) if not np.isfinite(sigma)
        )
        if unseen != self.unseen:
            self.unseen = unseen
            if unseen:
                self.log.info(f"vision: no marker found constrains {', '.join(unseen)}")
            else:
                self.log.info("vision: every joint constrained again")


class VisionBeside(Vision):
    """The vision beside the encoder (``vision_node``): its readings on their own topic, for the filter to fuse."""

    outputs = ("camera_reading", "detections")
    reading_port = "camera_reading"
    repeats = False  # the controller knows when its next reading is due


def jpeg(pixels: np.ndarray) -> bytes:
    """``pixels`` (RGB) as a JPEG."""
    import cv2

    ok, data = cv2.imencode(".jpg", pixels[:, :, ::-1], [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY])
    return data.tobytes() if ok else b""
