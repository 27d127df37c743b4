"""The encoder block, no ROS: its sampling grid, its delay and its seeded noise."""

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.blocks.block import Lines
from robot_controller.blocks.encoder import Encoder
from robot_controller.blocks.values import JointSample


def state(t_s: float, q: float = 0.0) -> dict:
    return {"true_state": JointSample(t_s, ["joint1"], np.array([q]), np.array([0.0]))}


def encoder(**params) -> Encoder:
    return Encoder(cfg.load_stack()["sensor_node"] | params, Lines())


def test_it_samples_on_its_grid_of_stamps_and_says_the_arm_at_start():
    block = encoder(rate_hz=50.0)
    assert "<robot" in block.start()["robot_description"]
    stamps = [k * 0.01 for k in range(6)]
    read = [t for t in stamps if "reading" in block.step(t, state(t))]
    assert read == [0.0, 0.02, 0.04]


def test_noise_is_the_seed_s_and_a_delay_reports_the_older_sample_with_its_stamp():
    a, b = encoder(seed=3), encoder(seed=3)
    assert a.step(0.0, state(0.0))["reading"].position == b.step(0.0, state(0.0))["reading"].position
    late = encoder(delay_s=0.02, position_noise_std=0.0, velocity_noise_std=0.0)
    readings = [late.step(k * 0.01, state(k * 0.01, q=float(k)))["reading"] for k in range(4)]
    assert [(round(r.stamp_s, 3), r.position[0]) for r in readings] == [(0.0, 0.0), (0.0, 0.0), (0.0, 0.0), (0.01, 1.0)]


def test_a_state_naming_other_joints_is_refused_with_its_reason():
    block = encoder()
    block.step(0.0, state(0.0))
    bad = JointSample(0.01, ["elbow"], np.array([0.0]), np.array([0.0]))
    assert block.step(0.01, {"true_state": bad}) == {}


def test_a_second_sensor_block_is_chosen_by_configuration_and_runs_in_process():
    from robot_controller.experiments import inprocess

    params = cfg.load_stack()
    params["sensor_node"]["block"] = "every_other_tick"
    sparse = inprocess.simulate(params, duration_s=4.0, seed=0)
    # Half the readings: the measured column changes every other tick only, and the loop still tracks.
    changes = np.count_nonzero(np.diff(sparse.measured[:, 0]))
    assert abs(changes - sparse.measured.shape[0] / 2) <= 1
    assert sparse.tracking_metrics(warmup_s=1.0)["tracking_rms_rad"] < 0.01
