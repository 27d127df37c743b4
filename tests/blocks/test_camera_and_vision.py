"""The camera and the vision blocks, no ROS: the camera's frames keep to the world's states (every 3rd of 100 Hz for
30 Hz), each published its latency after its exposure (the first at once), an empty image at the states between where
the world waits; a hidden link's markers are hidden in their window; the vision reads the joints from a frame with
their σs and correlation, repeats its last reading for an empty image as the loop's sensor (not beside the encoder),
and says every σ infinite when it finds no marker."""

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller.blocks.block import Lines
from robot_controller.blocks.camera import Camera, frame_ticks
from robot_controller.blocks.camera_chain import CameraChain
from robot_controller.blocks.values import CameraFrame, JointSample
from robot_controller.blocks.vision import Vision, VisionBeside
from robot_controller.core.errors import ConfigError


def state(t_s: float, q: float = 0.3) -> dict:
    return {"true_state": JointSample(t_s, ["joint1"], np.array([q]), np.array([0.0]))}


@pytest.fixture(scope="module")
def camera():
    block = Camera(cfg.node_defaults("camera_node"), Lines(), world_waits=True)
    yield block
    block.close()


def test_frames_keep_to_the_world_s_states_and_come_out_their_latency_after_their_exposure(camera):
    assert frame_ticks(30.0, 0.01) == 3 and frame_ticks(15.0, 0.01) == 7
    out = {round(k * 0.01, 2): camera.step(k * 0.01, state(k * 0.01)) for k in range(10)}
    frames = {t: o["image"].stamp_s for t, o in out.items() if o["image"].pixels.size}
    # Exposed at 0 (out at once), 0.03 (out at 0.06: 30 ms latency), 0.06 (out at 0.09).
    assert frames == {0.0: 0.0, 0.06: pytest.approx(0.03), 0.09: pytest.approx(0.06)}
    assert all(o["image"].pixels.size == 0 and o["image"].stamp_s == t for t, o in out.items() if t not in frames)
    image = out[0.06]["image"].pixels
    assert image.shape == (480, 640) and image.dtype == np.uint8 and image.std() > 1  # mono, noised, not blank
    assert out[0.06]["camera_info"].k[0, 0] > 0


def test_a_hidden_link_is_hidden_in_its_window_and_an_unknown_one_refused():
    params = cfg.node_defaults("camera_node") | {"occluded_link": "link1", "occlusion_s": [0.5, 1.0]}
    block = Camera(params, Lines(), world_waits=False)
    try:
        assert block.occluded_ids(0.4) == [] and len(block.occluded_ids(0.5)) == 12 and block.occluded_ids(1.5) == []
        with pytest.raises(ConfigError, match="occluded_link: 'elbow' carries no marker"):
            block.check_params(params | {"occluded_link": "elbow"})
    finally:
        block.close()


def test_the_vision_reads_the_joint_with_its_sigma_and_repeats_it_for_an_empty_image(camera):
    vision = Vision(cfg.node_defaults("sensor_node"), Lines(), world_waits=True)
    frame = camera.step(0.0, state(0.0, q=0.7)).get("image") if camera.frames == 0 else None
    if frame is None:  # the module's camera has run: a fresh one, its first frame out at once
        fresh = Camera(cfg.node_defaults("camera_node"), Lines(), world_waits=True)
        frame = fresh.step(0.0, state(0.0, q=0.7))["image"]
        fresh.close()
    reading = vision.step(0.0, {"image": frame})["reading"]
    assert reading.position[0] == pytest.approx(0.7, abs=0.003) and 0 < reading.position_std[0] < 0.01
    empty = CameraFrame(0.01, np.zeros((0, 0), dtype=np.uint8))
    assert vision.step(0.01, {"image": empty})["reading"] is reading
    assert VisionBeside(cfg.node_defaults("vision_node"), Lines(), world_waits=True).step(0.01, {"image": empty}) == {}
    blank = CameraFrame(0.02, np.full((480, 640), 128, dtype=np.uint8))
    unseen = vision.step(0.02, {"image": blank})["reading"]
    assert np.isinf(unseen.position_std).all() and unseen.position[0] == pytest.approx(0.7, abs=0.003)
    assert vision.step(0.03, {"image": "image encoding 'yuv422'"}) == {}  # a bad image: said, dropped


def test_the_chain_in_one_process_reads_the_joint_the_camera_saw():
    chain = CameraChain(cfg.node_defaults("camera_node"), cfg.node_defaults("sensor_node"), Lines(), world_waits=True)
    try:
        readings = [chain.step(k * 0.01, state(k * 0.01, q=-0.4)).get("reading") for k in range(7)]
    finally:
        chain.close()
    assert all(r is not None for r in readings)  # every tick answered: a frame's, or the last again
    assert {round(r.stamp_s, 2) for r in readings} == {0.0, 0.03}
    assert readings[-1].position[0] == pytest.approx(-0.4, abs=0.003)
