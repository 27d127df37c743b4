"""The planner block, no ROS: the reference sampled at each step from its first, the same on every clock, joint
trajectories taken or refused with the reason, a live change blended in, a shape change giving the parameters' motion
back, and the plan's warning said at start."""

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller.blocks.block import Lines, make_block
from robot_controller.blocks.planner import START_HOLD_S, Planner
from robot_controller.blocks.values import WaypointRequest
from robot_controller.core.errors import ConfigError
from robot_controller.core.reference.tolerances import INVALID_GOAL, INVALID_JOINTS
from robot_controller.parameters.consistency import trajectory_plan

PERIOD_S = 0.01


def planner(world_waits: bool = True, **params) -> tuple[Planner, Lines]:
    log = Lines()
    block = Planner(cfg.load_stack()["trajectory_planner"] | params, log, world_waits=world_waits)
    block.start()
    return block, log


def to(position: float, time_s: float = 1.0, stamp_s: float = 0.0, joints=("joint1",)) -> WaypointRequest:
    return WaypointRequest(stamp_s, tuple(joints), (time_s,), ((position,) * len(joints),), ((),), ((),))


def test_the_graph_spec_names_it_for_the_planner_node():
    block = make_block("trajectory_planner", cfg.load_stack()["trajectory_planner"], Lines(), world_waits=False)
    assert isinstance(block, Planner) and block.inputs[:2] == ("waypoints", "controller_waypoints")
    assert block.wake_period_s() == pytest.approx(PERIOD_S)  # publish_rate_hz 100


def test_each_step_samples_the_run_plans_trajectory_from_its_first_to_the_bit():
    params = cfg.load_stack()
    block = Planner(params["trajectory_planner"], Lines(), world_waits=True)
    block.start()
    trajectory = trajectory_plan(params).trajectory  # what the in-process loop samples itself
    for t in (np.arange(300) * PERIOD_S).tolist():
        data = block.step(t, {})["reference"].data
        assert data.shape == (4,) and data[-1] == t  # [q, q̇, q̈, sample_time_s]
        assert np.array_equal(data[:3], np.concatenate(trajectory.sample(t)))


def test_it_computes_the_same_whatever_its_hosts_clock():
    waits, _ = planner(world_waits=True)
    free, _ = planner(world_waits=False)
    times = [0.003, 0.0131, 0.02, 0.5, 0.5002, 2.25]  # a wall clock's jittered ticks: stepped when the host says
    for t in times:
        if t == 0.5:
            for block in (waits, free):
                block.step(t, {"waypoints": to(0.3)})
        assert np.array_equal(waits.step(t, {})["reference"].data, free.step(t, {})["reference"].data)
    assert waits.start_s == 0.003  # its time 0 is its first step


def test_a_joint_trajectory_before_the_first_step_is_refused_then_taken_and_held_at_its_end():
    block, log = planner()
    assert block.check_goal(to(0.4), 0.0) == (
        INVALID_GOAL,
        "the planner is not publishing yet (its consumers are not matched)",
    )
    assert block.step(0.0, {"waypoints": to(0.4)}) == {}
    assert log.lines[-1].startswith("joint trajectory refused: the planner is not publishing yet")
    told = []
    block.replaced.append(told.append)
    block.step(0.0, {})
    assert block.step(1.0, {"controller_waypoints": to(0.4, time_s=2.0)}) == {}
    assert told == ["a trajectory on the topic"] and log.lines[-1].startswith("joint trajectory taken: 1 point(s)")
    assert block.step(3.5, {})["reference"].data.tolist() == [0.4, 0.0, 0.0, 3.5]


def test_a_refused_joint_trajectory_leaves_the_motion_in_force_and_says_why():
    block, log = planner()
    block.step(0.0, {})
    before = block.reference_at(1.0)
    code, reason = block.take(to(0.4, joints=("elbow",)), 1.0)
    assert code == INVALID_JOINTS and reason == "unknown joint(s) ['elbow']: the arm's joints are ['joint1']"
    block.step(1.0, {"waypoints": to(4.0)})  # beyond the joint's range
    assert "joint trajectory refused:" in log.lines[-1] and block.waypoints is None
    assert np.array_equal(block.reference_at(1.0)[0], before[0])


def test_a_live_change_blends_from_the_reference_in_force_and_a_shape_change_ends_a_joint_trajectory():
    block, log = planner()
    block.step(0.0, {})
    block.step(1.0, {"waypoints": to(0.4)})
    told = []
    block.replaced.append(told.append)
    params = dict(block.params, amplitude=[0.5])
    block.check_params(params)
    at_s = 2.0
    before = block.reference_at(at_s)
    block.set_params(params, {"amplitude"}, at_s)
    assert told == ["a change of the parameters' motion"] and block.waypoints is None
    assert block.crossfade is not None and block.crossfade.start_s == at_s
    for got, want in zip(block.reference_at(at_s), before, strict=True):
        assert got == pytest.approx(want)  # no jump
    assert any(line.startswith("new sine blended in over") for line in log.lines)
    after = at_s + block.crossfade.duration_s + 0.1
    assert block.reference_at(after)[0][0] == pytest.approx(0.5 * np.sin(2 * np.pi * 0.5 * after))


def test_a_refused_plan_is_a_config_error_and_a_slowed_one_is_said_at_start():
    with pytest.raises(ConfigError, match="slow it down"):
        planner(mode="chirp", end_frequency_hz=3.0, feasibility="refuse", torque_max=[10.0])
    block, log = planner(mode="chirp", end_frequency_hz=3.0, torque_max=[10.0])
    assert len(log.lines) == 1 and "scaled in time ×" in log.lines[0]
    assert "slowed in time ×" in block.summary()


def test_a_robot_standing_elsewhere_is_led_from_where_it_stands_onto_the_motion():
    block, log = planner(start_position=[0.7])
    first = block.step(5.0, {})["reference"].data
    assert first[0] == pytest.approx(0.7) and first[1] == pytest.approx(0.0)  # where it stands, at rest
    assert "blended in" in "\n".join(log.lines)
    trajectory = trajectory_plan(cfg.load_stack()).trajectory
    after = [block.step(5.0 + t, {})["reference"].data for t in (np.arange(1, 1001) * PERIOD_S).tolist()]
    assert after[:50][-1][0] == pytest.approx(0.7), "held where it stands at first (its drive comes up meanwhile)"
    # the motion's time 0 once the hold is over, on it after the blend
    assert after[-1][0] == pytest.approx(trajectory.sample(10.0 - START_HOLD_S)[0][0], abs=1e-9)
