"""The drive block, no ROS: saturation, the start, stale commands, the timeout's stop and the e-stop."""

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.blocks.block import Lines
from robot_controller.blocks.drive import TIMELY_COMMANDS_TO_START, Drive
from robot_controller.blocks.values import Array, tick_label


def drive(world_waits: bool = False, **params) -> tuple[Drive, Lines]:
    log = Lines()
    values = cfg.load_stack()["motor_node"] | {"torque_max": [10.0]} | params
    return Drive(values, log, world_waits=world_waits), log


def command(torque: float, tick_s: float | None = None) -> Array:
    return Array(np.array([torque]), "" if tick_s is None else tick_label(tick_s))


def test_where_the_world_waits_the_first_command_moves_the_arm_saturated_and_its_tick_passed_on():
    block, _ = drive(world_waits=True)
    out = block.step(0.0, {"command": command(50.0, 0.0)})
    assert out["effort"].data.tolist() == [10.0] and out["effort"].label == tick_label(0.0)


def test_on_the_wall_clock_only_a_steady_stream_of_timely_commands_starts_it():
    block, _ = drive()
    outs = [block.step(0.01 * k, {"command": command(1.0, 0.01 * k)}) for k in range(TIMELY_COMMANDS_TO_START)]
    assert [("effort" in out) for out in outs] == [False] * (TIMELY_COMMANDS_TO_START - 1) + [True]


def test_a_command_older_than_its_age_limit_is_no_command():
    block, log = drive(world_waits=True)
    assert block.step(1.0, {"command": command(1.0, 0.5)}) == {}
    assert any("ms ago" in line for line in log.lines)


def test_silence_past_the_timeout_requests_the_brake_before_the_zero_torque():
    block, _ = drive(world_waits=True)
    block.step(0.0, {"command": command(2.0, 0.0)})
    timeout_s = block.params["command_timeout_s"]
    assert block.step(timeout_s / 2, {}) == {}
    assert block.step(timeout_s, {}) == {}
    out = block.step(1.5 * timeout_s, {})  # checked every half timeout, as its host wakes it
    assert list(out) == ["brake_request", "effort"] and out["brake_request"] is True
    assert out["effort"].data.tolist() == [0.0]


def test_the_estop_latches_until_released_and_a_bad_command_is_dropped_with_its_reason():
    block, log = drive(world_waits=True)
    assert block.step(0.0, {"estop": True})["brake_request"] is True
    assert block.step(0.01, {"command": command(1.0, 0.01)}) == {}
    assert block.step(0.02, {"estop": False}) == {"brake_request": False}
    assert "effort" in block.step(0.03, {"command": command(1.0, 0.03)})
    assert block.step(0.04, {"command": Array(np.array([np.nan]))}) == {}
    assert any("non-finite torque" in line for line in log.lines)
