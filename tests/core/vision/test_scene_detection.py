"""The rendered markers: where MuJoCo draws them is where the camera model projects them, in cv2's corner order;
hiding, noise, the detector's drawing."""

import mujoco
import numpy as np
import pytest

from robot_controller import resources
from robot_controller.core.errors import ConfigError
from robot_controller.core.model.mujoco_model import load_model
from robot_controller.core.vision.camera_model import CameraModel, default_camera
from robot_controller.core.vision.detection import MarkerDetector
from robot_controller.core.vision.marker_kinematics import MarkerChain
from robot_controller.core.vision.markers import Marker, MarkerLayout, matrix_to_quat, place_markers
from robot_controller.core.vision.scene import CAMERA_NAME, Renderer, add_pixel_noise, scene_spec

URDF = resources.default_urdf()
CAMERA = CameraModel([0.3, -1.2, 1.3], [0.3, 0.0, 1.0], 640, 480)


def _tilted(marker_id: int, position, angle_rad: float) -> Marker:
    """A marker on link1 facing roughly -y (the camera), turned about its normal by ``angle_rad``."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    x, y, normal = np.array([c, 0, s]), np.array([-s, 0, c]), np.array([0, -1.0, 0])
    tilt = np.array([[1, 0, 0], [0, np.cos(0.3), -np.sin(0.3)], [0, np.sin(0.3), np.cos(0.3)]])
    rotation = tilt @ np.stack([x, y, normal], axis=1)
    return Marker(marker_id, "link1", position, matrix_to_quat(rotation), 0.06)


@pytest.fixture(scope="module")
def single():
    layout = MarkerLayout((_tilted(5, [0.2, -0.05, 0.05], 0.0), _tilted(17, [0.45, -0.05, -0.05], 2.2)))
    with Renderer(URDF, layout, CAMERA) as renderer:
        yield renderer, layout


def test_rendered_corners_land_where_projected_in_cv2_order(single):
    renderer, layout = single
    position = np.array([0.3])
    detections = MarkerDetector().detect(renderer.render(position))
    assert sorted(detections) == [5, 17]
    chain = MarkerChain(load_model(URDF), layout, CAMERA)
    chain.pose(position)
    for marker_id in (5, 17):
        projected, _ = chain.project([marker_id])
        # Corner for corner (a rotated order would be off by the marker's side, ~40 px); the detector's
        # sub-pixel corners sit ~0.2-0.4 px inside the square's true corners (blur of the rendered edges).
        np.testing.assert_allclose(detections[marker_id], projected, atol=1.0)


def test_hidden_markers_are_not_drawn_until_shown(single):
    renderer, _ = single
    detector = MarkerDetector()
    renderer.hide([5])
    assert sorted(detector.detect(renderer.render(np.array([0.3])))) == [17]
    renderer.show_all()
    assert sorted(detector.detect(renderer.render(np.array([0.3])))) == [5, 17]


def test_pixel_noise_is_seeded_clipped_and_of_its_spread(single):
    renderer, _ = single
    image = renderer.render(np.array([0.0]))
    a = add_pixel_noise(image, 2.0, np.random.default_rng(4))
    b = add_pixel_noise(image, 2.0, np.random.default_rng(4))
    np.testing.assert_array_equal(a, b)
    assert a.dtype == np.uint8 and a.shape == image.shape
    middle = (image > 20) & (image < 235)  # away from the clipping
    spread = np.std(a[middle].astype(float) - image[middle])
    assert spread == pytest.approx(2.0, rel=0.15) if middle.sum() > 1000 else True
    with pytest.raises(ConfigError, match="pixel_noise_std"):
        add_pixel_noise(image, -1.0, np.random.default_rng(0))


def test_draw_outlines_a_copy(single):
    renderer, _ = single
    image = renderer.render(np.array([0.3]))
    detector = MarkerDetector()
    drawn = detector.draw(image, detector.detect(image))
    assert drawn.shape == image.shape and not np.array_equal(drawn, image)
    assert np.array_equal(detector.draw(image, {}), image)


def test_scene_has_the_camera_and_a_plate_per_marker():
    model = load_model(URDF)
    layout = place_markers(model, default_camera(model))
    compiled = scene_spec(URDF, layout, default_camera(model)).compile()
    assert compiled.camera(CAMERA_NAME).id >= 0
    plates = [g for g in range(compiled.ngeom) if compiled.geom(g).name.startswith("vision_marker_")]
    assert len(plates) == len(layout.markers)
    assert not compiled.geom_contype[plates].any() and not compiled.geom_conaffinity[plates].any()
    assert compiled.nq == model.nq and compiled.nlight >= 1
    assert mujoco.mj_name2id(compiled, mujoco.mjtObj.mjOBJ_BODY, layout.markers[0].body) >= 0


def test_markers_on_an_unknown_body_are_refused():
    layout = MarkerLayout((Marker(0, "no_such_link", [0, 0, 0], [1, 0, 0, 0], 0.05),))
    with pytest.raises(ConfigError, match="no_such_link"):
        scene_spec(URDF, layout, CAMERA)


def test_layout_helpers():
    model = load_model(URDF)
    layout = place_markers(model, default_camera(model))
    assert layout.bodies() == ("link1",)
    assert len(set(layout.ids())) == len(layout.markers) >= 6
    assert layout.without([0, 1]).ids() == layout.ids()[2:]
    moved = layout.with_error(0.002, 0.01, np.random.default_rng(0))
    offsets = [np.linalg.norm(a.position_m - b.position_m) for a, b in zip(layout.markers, moved.markers, strict=True)]
    assert 0 < np.mean(offsets) < 0.01
    assert place_markers(model, default_camera(model)) == layout  # deterministic
    assert moved != layout
    corners = layout.markers[0].corners_in_body()
    assert np.linalg.norm(corners[0] - corners[1]) == pytest.approx(layout.markers[0].size_m)
