"""Joint angles from rendered, noisy, detected markers: the one-joint arm and the Panda, occlusions, a
calibration error, and a camera that cannot see the arm."""

import time

import numpy as np
import pytest

from robot_controller import resources
from robot_controller.core.errors import ConfigError
from robot_controller.core.model.mujoco_model import load_model
from robot_controller.core.vision.camera_model import CameraModel, default_camera
from robot_controller.core.vision.detection import MarkerDetector
from robot_controller.core.vision.joint_solver import (
    JointSolver,
    observable_joints,
    unobservable_reason,
    visible_markers,
)
from robot_controller.core.vision.marker_kinematics import MarkerChain
from robot_controller.core.vision.markers import place_markers
from robot_controller.core.vision.scene import Renderer, add_pixel_noise
from robot_controller.robots.description import urdf_of

ONE_DOF = resources.default_urdf()
PIXEL_NOISE = 2.0  # intensity levels of 255
#: Within the Panda's limits, home (the SRDF's "ready") and four others across the workspace.
PANDA_POSES = np.array(
    [
        [0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785],
        [0.5, -0.3, 0.4, -1.8, 0.6, 2.0, -0.5],
        [-0.8, 0.4, -0.5, -2.5, -0.7, 1.2, 1.5],
        [1.2, 0.2, 0.8, -1.2, 1.0, 2.5, 0.0],
        [-0.3, -1.0, 0.3, -2.8, 0.4, 0.8, -1.2],
    ]
)


class Arm:
    def __init__(self, urdf):
        self.urdf = urdf
        self.model = load_model(urdf)
        self.camera = default_camera(self.model)
        self.layout = place_markers(self.model, self.camera)
        self.renderer = Renderer(urdf, self.layout, self.camera)
        self.solver = JointSolver(urdf, self.layout, self.camera)
        self.detector = MarkerDetector()

    def detect(self, position, rng, hidden=()):
        self.renderer.hide(hidden)
        try:
            image = add_pixel_noise(self.renderer.render(position), PIXEL_NOISE, rng)
        finally:
            self.renderer.show_all()
        return self.detector.detect(image)


@pytest.fixture(scope="module")
def one_dof():
    arm = Arm(ONE_DOF)
    yield arm
    arm.renderer.close()


@pytest.fixture(scope="module")
def panda():
    arm = Arm(urdf_of("panda"))
    yield arm
    arm.renderer.close()


@pytest.fixture(scope="module")
def panda_detections(panda):
    rng = np.random.default_rng(11)
    return [panda.detect(q, rng) for q in PANDA_POSES]


@pytest.mark.parametrize("angle_rad", [-2.5, -1.0, 0.0, 0.6, 2.0])
def test_one_joint_arm_within_two_milliradians(one_dof, angle_rad):
    rng = np.random.default_rng(int(100 * angle_rad) % 1000)
    detections = one_dof.detect(np.array([angle_rad]), rng)
    assert detections
    solution = one_dof.solver.solve(detections, np.array([angle_rad + 0.1]))
    assert abs(solution.position[0] - angle_rad) <= 2e-3
    assert np.isfinite(solution.std).all() and solution.std[0] < 5e-3
    assert solution.residual_px < 1.0


def test_panda_every_joint_within_ten_milliradians(panda, panda_detections):
    errors = []
    for q, detections in zip(PANDA_POSES, panda_detections, strict=True):
        guess = q + 0.05 * np.where(np.arange(7) % 2, 1.0, -1.0)
        solution = panda.solver.solve(detections, guess)
        assert solution is not None and np.isfinite(solution.std).all()
        errors.append(np.abs(solution.position - q))
    errors = np.array(errors)
    assert errors.max() <= 10e-3, np.round(errors * 1e3, 1)


def test_panda_solve_is_fast(panda, panda_detections):
    guess = PANDA_POSES[0] + 0.01
    panda.solver.solve(panda_detections[0], guess)
    start = time.perf_counter()
    for _ in range(10):
        panda.solver.solve(panda_detections[0], guess)
    assert (time.perf_counter() - start) / 10 < 0.02  # ~3 ms here; slack for a shared machine


def test_panda_every_joint_observable_by_the_default_camera(panda):
    assert observable_joints(panda.model, panda.layout, panda.camera, PANDA_POSES).all()


def test_hiding_a_middle_link_keeps_every_joint_constrained(panda):
    q = PANDA_POSES[1]
    hidden = panda.layout.on("panda_link4")
    detections = panda.detect(q, np.random.default_rng(3), hidden=hidden)
    assert not set(detections) & set(hidden)
    solution = panda.solver.solve(detections, q + 0.03)
    assert np.isfinite(solution.std).all()
    assert np.abs(solution.position - q).max() < 0.02


def test_hiding_the_last_link_loses_the_last_joint_only(panda):
    q = PANDA_POSES[1]
    hidden = panda.layout.on("panda_link7")
    detections = panda.detect(q, np.random.default_rng(4), hidden=hidden)
    solution = panda.solver.solve(detections, q + 0.03)
    assert np.isfinite(solution.std[:6]).all()
    assert solution.std[6] == np.inf
    assert solution.position[6] == pytest.approx(q[6] + 0.03)  # nothing moved it from the guess


def test_calibration_error_degrades_gracefully(panda, panda_detections):
    believed = panda.layout.with_error(0.002, 0.01, np.random.default_rng(0))
    solver = JointSolver(panda.urdf, believed, panda.camera)
    errors, residuals = [], []
    for q, detections in zip(PANDA_POSES, panda_detections, strict=True):
        solution = solver.solve(detections, q + 0.05)
        assert solution is not None
        errors.append(np.abs(solution.position - q).max())
        residuals.append(solution.residual_px)
    assert max(errors) < 0.05
    assert np.mean(residuals) > 0.3  # the error shows in the fit


def test_an_outlier_marker_is_dropped(one_dof):
    q = np.array([0.6])
    detections = one_dof.detect(q, np.random.default_rng(5))
    spoiled = dict(detections)
    wrong = next(iter(spoiled))
    spoiled[wrong] = spoiled[wrong] + 25.0
    solution = one_dof.solver.solve(spoiled, q + 0.1)
    if len(detections) > 1:
        assert wrong not in solution.markers_used and abs(solution.position[0] - q[0]) < 3e-3
    assert one_dof.solver.solve({}, q) is None
    assert one_dof.solver.solve({999: np.zeros((4, 2))}, q) is None


def test_a_camera_looking_away_observes_nothing(one_dof):
    away = CameraModel([0.0, -1.5, 1.0], [0.0, -3.0, 1.0], 640, 480)
    observable = observable_joints(ONE_DOF, one_dof.layout, away, np.array([[0.0], [1.0]]))
    assert not observable.any()
    assert "joint1" in unobservable_reason(one_dof.model, observable)
    assert visible_markers(MarkerChain(one_dof.model, one_dof.layout, away), np.array([0.0])) == ()
    assert observable_joints(ONE_DOF, one_dof.layout, one_dof.camera, np.array([[0.0], [1.0]])).all()


def test_bad_pixel_std_is_refused(one_dof):
    with pytest.raises(ConfigError, match="pixel_std_px"):
        JointSolver(ONE_DOF, one_dof.layout, one_dof.camera, pixel_std_px=0.0)
