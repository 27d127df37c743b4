"""The pinhole camera: OpenCV's projection, MuJoCo's camera pose, the default camera of any arm (no rendering)."""

import cv2
import mujoco
import numpy as np
import pytest

from robot_controller.core.errors import ConfigError
from robot_controller.core.model.mujoco_model import load_model
from robot_controller.core.vision.camera_model import CameraModel, default_camera, workspace_sphere
from robot_controller.robots.description import urdf_of


def test_projection_agrees_with_opencv():
    camera = CameraModel([1.2, -0.7, 1.5], [0.1, 0.2, 0.4], 640, 480, 50.0)
    points = np.random.default_rng(0).uniform(-0.5, 0.5, (20, 3)) + camera.target_m
    rotation, translation = camera.world_to_camera()
    rvec, _ = cv2.Rodrigues(rotation)
    expected, _ = cv2.projectPoints(points, rvec, translation, camera.intrinsics(), np.zeros(5))
    np.testing.assert_allclose(camera.project(points), expected.reshape(-1, 2), atol=1e-6)
    # The target is on the optical axis: the image's centre.
    np.testing.assert_allclose(camera.project(camera.target_m[None]), [[319.5, 239.5]], atol=1e-9)


def test_camera_frame_is_right_down_forward_and_mujoco_quat_matches():
    camera = CameraModel([0.0, -2.0, 1.0], [0.0, 0.0, 1.0], 64, 48)
    rotation, _ = camera.world_to_camera()
    np.testing.assert_allclose(rotation, [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-12)
    # MuJoCo's camera: x right, y up, looking along -z.
    matrix = np.zeros(9)
    mujoco.mju_quat2Mat(matrix, camera.mujoco_quat())
    np.testing.assert_allclose(matrix.reshape(3, 3), np.stack([rotation[0], -rotation[1], -rotation[2]], 1), atol=1e-9)
    # Looking straight down still gives a proper rotation.
    down = CameraModel([0.0, 0.0, 3.0], [0.0, 0.0, 0.0], 64, 48)
    rotation, _ = down.world_to_camera()
    np.testing.assert_allclose(rotation @ rotation.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(rotation) == pytest.approx(1.0)


def test_in_view_needs_front_and_inside():
    camera = CameraModel([0.0, -2.0, 1.0], [0.0, 0.0, 1.0], 640, 480)
    points = np.array([[0, 0, 1], [0, -3, 1], [5, 0, 1], [0.1, 0, 1.1]], dtype=float)
    np.testing.assert_array_equal(camera.in_view(points), [True, False, False, True])


@pytest.mark.parametrize(
    ("kwargs", "key"),
    [
        ({"position_m": [0, 0, 1], "target_m": [0, 0, 1]}, "camera_target_m"),
        ({"position_m": [0, np.nan, 1]}, "camera_position_m"),
        ({"width_px": 8}, "image_width"),
        ({"height_px": 10.5}, "image_height"),
        ({"fovy_deg": 180.0}, "fovy"),
    ],
)
def test_bad_values_name_their_key(kwargs, key):
    values = {"position_m": [0, -2, 1], "target_m": [0, 0, 1], "width_px": 64, "height_px": 48} | kwargs
    with pytest.raises(ConfigError, match=key):
        CameraModel(**values)


@pytest.mark.parametrize("robot", ["one_dof", "planar2", "scara", "panda"])
def test_default_camera_holds_the_workspace_sphere(robot):
    model = load_model(urdf_of(robot))
    camera = default_camera(model)
    centre, radius = workspace_sphere(model)
    # Points on the sphere's silhouette, and its extremes along the world axes, are all in the image.
    directions = np.random.default_rng(1).normal(size=(200, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    assert camera.in_view(centre + radius * directions).all()
    if robot in ("one_dof", "planar2"):  # parallel hinge axes: looking along them
        forward = camera.world_to_camera()[0][2]
        assert abs(forward @ [0, 1, 0]) == pytest.approx(1.0)
    if robot == "panda":
        assert radius == pytest.approx(1.13, abs=0.05)
