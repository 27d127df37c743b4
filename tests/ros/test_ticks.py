"""The clock mode and the clock a node's block is stepped by are chosen once, from the node's parameters."""

import pytest

from robot_controller.ros.ticks import ClockMode, clock_mode, tick_source_class


@pytest.mark.parametrize(
    ("params", "mode"),
    [
        ({}, ClockMode.WALL),
        ({"lockstep": False, "real_time_factor": 1.0}, ClockMode.WALL),
        ({"lockstep": True, "real_time_factor": 1.0}, ClockMode.PACED),
        ({"lockstep": True, "real_time_factor": 0.0}, ClockMode.STEPPED),
        ({"lockstep": True}, ClockMode.STEPPED),  # a node without the world's pace: sim time all the same
    ],
)
def test_the_parameters_say_the_clock_mode(params, mode):
    assert clock_mode(params) is mode
    assert mode.world_waits is (mode is not ClockMode.WALL)


@pytest.mark.parametrize(
    ("node", "mode", "name"),
    [
        ("simulator", ClockMode.WALL, "WallClock"),
        ("simulator", ClockMode.PACED, "PacedClock"),
        ("simulator", ClockMode.STEPPED, "SteppedClock"),
        ("pid_controller", ClockMode.WALL, "TimerTicks"),
        ("pid_controller", ClockMode.PACED, "PairedTicks"),
        ("trajectory_planner", ClockMode.WALL, "PlannerTimer"),
        ("trajectory_planner", ClockMode.STEPPED, "PlannerGrid"),
        ("sensor_node", ClockMode.STEPPED, "OnInput"),
        ("motor_node", ClockMode.WALL, "OnInput"),
    ],
)
def test_each_node_has_one_clock_per_mode_and_each_is_a_tick_source(node, mode, name):
    source = tick_source_class(node, mode)
    assert source.__name__ == name
    for method in ("start", "take", "finish"):
        assert callable(getattr(source, method)), (name, method)
