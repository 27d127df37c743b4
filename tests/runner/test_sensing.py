"""``run --sensing``'s parameters, checked before anything starts (no ROS): a camera in the encoder's place gets the
vision in sensor_node and a controller that waits for its slower, later readings; beside the encoder, the controller
knows when its frames are due on sim time and does not wait in the paced world; what cannot work is refused in one
line, naming the key."""

import numpy as np
import pytest

from robot_controller.core.errors import ConfigError
from robot_controller.runner import plan, sensing
from robot_controller.runner.options import RunOptions
from robot_controller.scoring.camera_figures import camera_figures, camera_line


def params(**options):
    return RunOptions(**options).params()


def test_a_camera_in_the_encoder_s_place():
    out = sensing.with_sensing(params(), "camera")
    assert out["sensor_node"]["block"] == "vision" and out["pid_controller"]["trigger"] == "timer"
    # Frames every 30 ms, 30 ms late: the watchdog waits two frames and the latency, a reading may be 110 ms old.
    assert out["pid_controller"]["watchdog_periods"] == 9 and out["pid_controller"]["max_reading_age_s"] == 0.11
    assert out["camera_node"]["urdf_path"] == out["simulator"]["urdf_path"]


@pytest.mark.parametrize("sim_time", [True, False])
def test_a_camera_beside_the_encoder(sim_time):
    out = sensing.with_sensing(params(), "both", sim_time=sim_time)
    ctrl = out["pid_controller"]
    assert out["sensor_node"]["block"] == "encoder" and ctrl["watchdog_periods"] == 5  # the encoder drives the loop
    assert ctrl["camera_period_s"] == pytest.approx(0.03) and ctrl["camera_latency_s"] == 0.03
    assert (ctrl["camera_wait_s"] > 0) is sim_time and out["camera_node"]["every_state"] is sim_time


def test_what_cannot_work_is_refused_in_one_line():
    no_filter = params()
    no_filter["pid_controller"]["estimator"] = "none"
    with pytest.raises(ConfigError, match="estimator kalman"):
        sensing.with_sensing(no_filter, "camera")
    slow = params()
    slow["camera_node"]["camera_rate_hz"] = 4.0
    with pytest.raises(ConfigError, match="camera_node.camera_rate_hz 4 .* more than the controller may coast"):
        sensing.with_sensing(slow, "camera")
    away = params()
    away["camera_node"]["camera_position_m"], away["camera_node"]["camera_target_m"] = [0, -1.5, 1], [0, -3, 1]
    with pytest.raises(ConfigError, match=r"camera_position_m \[0, -1.5, 1\]: the camera does not see joint1"):
        sensing.with_sensing(away, "camera")
    for flag in ({"single_process": True}, {"nodes": ("simulator",), "run_id": "a"}):
        options = RunOptions(sensing="camera", **flag)
        with pytest.raises(ConfigError, match="--sensing camera: not with"):
            plan.check(options.params(), options)


def test_the_camera_s_figures_and_its_summary_line():
    times = np.arange(10) * 0.03
    std = np.full((10, 2), 0.002)
    std[3:5, 1] = np.inf  # the second joint unseen in two frames
    std[7] = np.inf  # no marker found
    figures = camera_figures(times, std, ["shoulder", "elbow"])
    assert figures["camera_rate_hz"] == pytest.approx(33.333, rel=1e-3) and figures["camera_frames_lost"] == 1
    assert figures["camera_detection_rate"] == 0.7 and figures["camera_unseen_s"] == {"shoulder": 0.03, "elbow": 0.09}
    line = camera_line({"sensing": "camera", **figures})
    assert line.startswith("a camera at 33.3 Hz: 10 frames, 1 lost (no marker found), every joint seen in 70.0 %")
    assert line.endswith("for want of a marker: shoulder 0.03 s, elbow 0.09 s")
    assert camera_line({"sensing": "encoders"}) is None
