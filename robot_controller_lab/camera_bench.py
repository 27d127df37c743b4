"""What a camera frame costs and how well the joints come out of it, per robot, with no ROS: the arm moving along a
smooth path within its limits (a small sine about a mid-range pose) seen by the default camera at 640 × 480, each frame
rendered as the camera node renders it (MuJoCo offscreen, RGB → mono, pixel noise σ 2 levels: ``Darkroom._render``),
its markers detected and the joints solved from the previous solution, as the vision does. The figures: each step's
median wall time per frame, the three together, and the RMS of solved − true over frames and joints. Timings are
figures only, never checked against a limit."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

ROBOTS = ("one_dof", "panda")
WIDTH_PX, HEIGHT_PX = 640, 480
PIXEL_NOISE_STD = 2.0  #: intensity levels of 255, the parameter ``pixel_noise_std``'s default
CORNER_STD_PX = 1.0  #: the parameter ``corner_std_px``'s default (scales the σ only, not the solution)
FRAME_RATE_HZ = 30.0  #: the path's time step per frame (``camera_rate_hz``'s default)
PATH_HZ = 0.5  #: the sine's frequency along the path
#: the pose the arm moves about; the one-joint arm moves about the middle of its range
PANDA_CENTRE = (0.0, -0.8, 0.0, -2.3, 0.0, 1.6, 0.8)
AMPLITUDE_RAD = {"one_dof": 0.4, "panda": 0.15}
MIN_FRAMES = 5  #: measured however short the duration
FIGURES = ("render_ms", "detect_ms", "solve_ms", "frame_cpu_ms", "joint_error_mrad")
KEYS = tuple(f"camera_{figure}_{robot}" for robot in ROBOTS for figure in FIGURES)


@dataclass(frozen=True)
class Sweep:
    """The arm's path: ``centre + amplitude · sin(2π f t + phase_j)`` per joint, clipped into its limits."""

    centre: np.ndarray
    amplitude: np.ndarray
    lower: np.ndarray
    upper: np.ndarray

    def at(self, t_s: float) -> np.ndarray:
        phase = np.arange(len(self.centre)) * 0.7  # the joints out of step: every one moves at every frame
        q = self.centre + self.amplitude * np.sin(2 * np.pi * PATH_HZ * t_s + phase)
        return np.clip(q, self.lower, self.upper)


def urdf_of(robot: str) -> Path:
    from robot_controller import resources
    from robot_controller.robots import urdf_of as robot_urdf

    return resources.resolve_urdf("") if robot == "one_dof" else robot_urdf(robot)


def path_of(robot: str, model: Any) -> Sweep:
    from robot_controller.core.model.mujoco_model import position_ranges

    ranges = position_ranges(model)
    lower, upper = ranges[:, 0], ranges[:, 1]
    if robot == "panda":
        centre = np.array(PANDA_CENTRE, dtype=float)
    else:
        centre = np.where(np.isfinite(lower) & np.isfinite(upper), 0.5 * (lower + upper), 0.0)
    amplitude = np.full(model.njnt, AMPLITUDE_RAD.get(robot, 0.15))
    return Sweep(centre, amplitude, lower, upper)


def frames(
    robot: str, duration_s: float, clock: Callable[[], float] = time.perf_counter, seed: int = 0
) -> dict[str, Any]:
    """Frames of ``robot`` for ``duration_s`` of wall clock (at least :data:`MIN_FRAMES`): its figures, keyed as in
    :data:`KEYS` (``camera_…_<robot>``), and ``camera_frames_<robot>`` (how many, not a bench key)."""
    import cv2

    from robot_controller.core.model import load_model
    from robot_controller.core.vision.camera_model import default_camera
    from robot_controller.core.vision.detection import MarkerDetector
    from robot_controller.core.vision.joint_solver import JointSolver
    from robot_controller.core.vision.markers import place_markers
    from robot_controller.core.vision.scene import Renderer, add_pixel_noise

    urdf = urdf_of(robot)
    model = load_model(urdf)
    camera = default_camera(model, WIDTH_PX, HEIGHT_PX)
    layout = place_markers(model, camera)
    detector = MarkerDetector()
    solver = JointSolver(urdf, layout, camera, CORNER_STD_PX)
    path = path_of(robot, model)
    rng = np.random.default_rng(seed)
    times: dict[str, list[float]] = {"render": [], "detect": [], "solve": []}
    errors: list[np.ndarray] = []
    guess = path.at(0.0)
    with Renderer(urdf, layout, camera) as renderer:
        renderer.render(guess)  # GL's set-up: not a frame
        ends = clock() + duration_s
        k = 0
        while k < MIN_FRAMES or clock() < ends:
            true = path.at(k / FRAME_RATE_HZ)
            started = clock()
            gray = cv2.cvtColor(renderer.render(true), cv2.COLOR_RGB2GRAY)
            image = add_pixel_noise(gray, PIXEL_NOISE_STD, rng)
            rendered = clock()
            detections = detector.detect(image)
            detected = clock()
            solution = solver.solve(detections, guess) if detections else None
            solved = clock()
            if solution is not None:
                guess = solution.position
            times["render"].append(rendered - started)
            times["detect"].append(detected - rendered)
            times["solve"].append(solved - detected)
            errors.append(guess - true)
            k += 1
    ms = {step: 1e3 * np.asarray(values) for step, values in times.items()}
    figures = {f"camera_{step}_ms_{robot}": float(np.median(values)) for step, values in ms.items()}
    figures[f"camera_frame_cpu_ms_{robot}"] = float(np.median(ms["render"] + ms["detect"] + ms["solve"]))
    figures[f"camera_joint_error_mrad_{robot}"] = float(1e3 * np.sqrt(np.mean(np.square(errors))))
    figures[f"camera_frames_{robot}"] = k
    return figures


def camera_figures(duration_s: float, robots: tuple[str, ...] = ROBOTS) -> dict[str, Any]:
    """:data:`KEYS` for ``robots``, each robot's frames for ``duration_s``; a robot whose frames could not be made (no
    EGL, say) gives ``camera_failure`` saying why, its figures unmeasured."""
    figures: dict[str, Any] = {}
    failures = []
    for robot in robots:
        try:
            measured = frames(robot, duration_s)
        except Exception as exc:  # noqa: BLE001 - any reason a frame cannot be made: said, the others measured
            failures.append(f"{robot}: {type(exc).__name__}: {exc}"[:300])
            continue
        figures.update({key: value for key, value in measured.items() if key in KEYS})
    if failures:
        figures["camera_failure"] = "; ".join(failures)
    return figures
