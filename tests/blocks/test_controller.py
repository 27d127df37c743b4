"""The controller block, no ROS: it ticks when stepped, says its waits, writes a labelled command and the state row,
is the core's JointController to the bit, takes a gain change at a tick, and leaves the start's brakes alone where
the world waits."""

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller.blocks.block import Lines
from robot_controller.blocks.controller import Controller
from robot_controller.blocks.values import Array, JointSample, labelled_tick_s
from robot_controller.core.controller import JointController, Status, state_layout

PERIOD_S = 0.01


def controller(world_waits: bool = True, **params) -> tuple[Controller, Lines]:
    log = Lines()
    values = cfg.load_stack()["pid_controller"] | {"lockstep": world_waits} | params
    return Controller(values, log, world_waits=world_waits), log


def reading(t_s: float, q: float, v: float = 0.0) -> JointSample:
    return JointSample(t_s, ["joint1"], np.array([q]), np.array([v]))


def reference(t_s: float) -> Array:
    q, v, a = np.sin(t_s), np.cos(t_s), -np.sin(t_s)
    return Array(np.array([q, v, a, t_s]))


def test_before_its_first_reading_it_writes_nothing_and_says_it_waits_once():
    block, log = controller()
    assert block.step(0.0, {}) == {} and block.step(PERIOD_S, {}) == {}
    assert sum("waiting for the first valid /joint_states reading" in line for line in log.lines) == 1


def test_a_tick_writes_its_command_labelled_with_its_time_and_every_term_on_the_state_row():
    block, _ = controller()
    out = block.step(0.0, {"reading": reading(0.0, 0.1), "reference": reference(0.0)})
    assert labelled_tick_s(out["command"].label) == pytest.approx(0.0)
    row = out["state"].data
    assert row.size == sum(size for _, size in block.state_blocks) and block.state_blocks[0] == ("time_s", 1)
    decoded = state_layout.decode(row, 1)
    assert decoded["command"].tolist() == out["command"].data.tolist()
    assert block.status in (Status.OK, Status.REACQUIRING)


def test_the_block_commands_what_the_core_s_controller_commands_to_the_bit():
    block, _ = controller()
    values = cfg.load_stack()["pid_controller"] | {"lockstep": True}
    core = JointController(cfg.controller_config(values, 1), 1, block.dynamics)
    q = 0.0
    for k in range(200):
        t_s = k * PERIOD_S
        sample = reading(t_s, q, 0.1)
        out = block.step(t_s, {"reading": sample, "reference": reference(t_s)})
        core.set_reference(t_s, *reference(t_s).data[:3].reshape(3, 1), t_s)
        core.set_measurement(t_s, t_s, sample.position, sample.velocity)
        assert out["command"].data.tolist() == core.update(t_s).command.tolist()
        q += 0.001 * out["command"].data[0]


def test_a_gain_change_takes_effect_at_the_next_tick_and_the_law_says_itself_again():
    block, log = controller(controller_type="pid", kp=[40.0])
    before = block.reports.law_in_force
    changed = dict(block.params, kp=[80.0])
    block.check_params(changed)
    block.set_params(changed, {"kp"})
    assert block.reports.law_in_force == before and block.controller.config.pid.kp[0] == 40.0  # not before a tick
    block.step(0.0, {"reading": reading(0.0, 0.0), "reference": reference(0.0)})
    assert block.controller.config.pid.kp[0] == 80.0 and block.reports.law_in_force != before
    assert block.reports.law_in_force in " ".join(log.lines)


def test_a_change_whose_law_does_not_stabilise_is_refused_when_checked():
    block, _ = controller(controller_type="lqr")
    with pytest.raises(ValueError):
        block.check_params(dict(block.params, lqr_r=-1.0))


@pytest.mark.parametrize("world_waits", [True, False])
def test_the_start_s_brakes_are_left_alone_only_where_the_world_waits(world_waits):
    block, _ = controller(world_waits=world_waits)
    block.step(0.0, {"reading": reading(0.0, 0.0), "reference": reference(0.0)})
    block.take(0.0, {"brakes": Array(np.array([1.0]), "engaged:start")})
    statuses = set()
    for k in range(1, 100):  # heard, the brakes make each tick start again from the measurement
        block.step(k * PERIOD_S, {"reading": reading(k * PERIOD_S, 0.0), "reference": reference(k * PERIOD_S)})
        statuses.add(block.status)
    assert (statuses == {Status.REACQUIRING}) != world_waits
