"""The bench's camera scenario: a frame's render, detection and solve timed per robot, and the joints' error, with no
ROS. Timings are figures: only that they are there and positive is checked."""

import math

from robot_controller_lab import bench, camera_bench


def test_the_camera_scenario_declares_every_figure_per_robot():
    (scenario,) = [s for s in bench.SCENARIOS if s.name == "camera"]
    assert scenario.keys == camera_bench.KEYS
    for robot in ("one_dof", "panda"):
        for figure in ("render_ms", "detect_ms", "solve_ms", "frame_cpu_ms", "joint_error_mrad"):
            assert f"camera_{figure}_{robot}" in scenario.keys


def test_the_camera_scenario_measures_both_robots(tmp_path):
    (scenario,) = [s for s in bench.SCENARIOS if s.name == "camera"]
    # A tiny duration: each robot's few frames (camera_bench.MIN_FRAMES at least).
    figures = scenario.measure(bench.Run({}, tmp_path, 0.2, True, {}))
    assert "camera_failure" not in figures, figures.get("camera_failure")
    assert set(figures) == set(scenario.keys)
    for key in scenario.keys:
        assert math.isfinite(figures[key]) and figures[key] > 0, key
    assert figures["camera_joint_error_mrad_one_dof"] < 5.0


def test_the_path_stays_within_the_limits_and_moves_every_joint():
    from robot_controller.core.model import load_model

    model = load_model(camera_bench.urdf_of("panda"))
    sweep = camera_bench.path_of("panda", model)
    poses = [sweep.at(k / camera_bench.FRAME_RATE_HZ) for k in range(60)]
    assert all(((q >= sweep.lower) & (q <= sweep.upper)).all() for q in poses)
    assert (abs(poses[1] - poses[0]) > 0).all()
