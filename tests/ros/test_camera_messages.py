"""The camera's messages and back (no graph): an image mono8, rgb8 and bgr8 read as the frame it was; an empty image
is "no frame at this tick"; one whose sizes disagree or whose encoding is not taken is refused with its reason; a
camera's reading says each joint's σ and their correlation on its frame id, and no velocity; CameraInfo carries K."""

import numpy as np
from sensor_msgs.msg import CameraInfo, Image, JointState

from robot_controller.blocks.values import CameraCalibration, CameraFrame, JointSample
from robot_controller.ros.messages import decode, encode


def test_images_go_and_come_back_as_the_frames_they_were():
    mono = np.arange(12, dtype=np.uint8).reshape(3, 4)
    back = decode(encode(CameraFrame(1.5, mono), Image()))
    np.testing.assert_array_equal(back.pixels, mono)
    assert back.stamp_s == 1.5
    rgb = np.arange(36, dtype=np.uint8).reshape(3, 4, 3)
    msg = encode(CameraFrame(0.0, rgb), Image())
    assert msg.encoding == "rgb8" and msg.step == 12
    np.testing.assert_array_equal(decode(msg).pixels, rgb)
    msg.encoding = "bgr8"
    np.testing.assert_array_equal(decode(msg).pixels, rgb[:, :, ::-1])
    assert decode(encode(CameraFrame(2.0, np.zeros((0, 0), np.uint8)), Image())).pixels.size == 0


def test_an_image_that_cannot_be_a_frame_is_refused_with_its_reason():
    msg = encode(CameraFrame(0.0, np.zeros((3, 4), np.uint8)), Image())
    msg.encoding = "yuv422"
    assert "image encoding 'yuv422'" in decode(msg)
    msg.encoding, msg.height = "mono8", 5
    assert "12 bytes, expected 20" in decode(msg)


def test_a_camera_s_reading_says_its_sigmas_and_correlation_and_no_velocity():
    rho = np.array([[1.0, -0.5], [-0.5, 1.0]])
    sample = JointSample(0.25, ["a", "b"], np.array([0.1, 0.2]), np.zeros(2), None, np.array([0.002, np.inf]), rho)
    msg = encode(sample, JointState())
    assert list(msg.velocity) == [] and msg.header.frame_id.startswith("position_std:0.002,inf;correlation:")
    back = decode(msg)
    np.testing.assert_array_equal(back.position_std, [0.002, np.inf])
    np.testing.assert_allclose(back.position_correlation, rho)
    np.testing.assert_array_equal(back.velocity, [0.0, 0.0])


def test_camera_info_carries_the_intrinsics():
    k = np.array([[500.0, 0, 320], [0, 500.0, 240], [0, 0, 1]])
    back = decode(encode(CameraCalibration(0.0, 640, 480, k), CameraInfo()))
    np.testing.assert_array_equal(back.k, k)
    assert (back.width_px, back.height_px) == (640, 480)
