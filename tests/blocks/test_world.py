"""The world block, no ROS: the effort in force and its limits, the brakes and their reasons, the e-stop, the
disturbance asked for and scheduled, and physics stepped exactly as its plant alone steps it."""

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.blocks.block import Lines
from robot_controller.blocks.values import Array
from robot_controller.blocks.world import World
from robot_controller.core.model import MujocoPlant


def world(**params) -> tuple[World, Lines]:
    log = Lines()
    return World(cfg.load_stack()["simulator"] | params, log, world_waits=True), log


def effort(*torque: float) -> Array:
    return Array(np.array(torque, dtype=float))


def test_it_starts_braked_and_the_first_effort_releases_the_brakes_and_acts():
    block, _ = world()
    assert block.braked_for("start")
    out = block.step(0.01, {"effort": effort(1.0)})
    assert out["brakes"].label == "engaged:" and out["brakes"].data.tolist() == [0.0]
    assert out["true_state"].effort.tolist() == [1.0] and out["true_state"].stamp_s == pytest.approx(0.01)
    assert block.time_ns == 10_000_000 and not block.braked_for("start")


def test_an_effort_beyond_the_urdfs_limit_is_clamped_and_a_bad_one_dropped():
    block, log = world()
    limit = block.plant.effort_limit[0]
    assert block.check_effort(effort(limit + 5.0)).tolist() == [limit]
    assert block.check_effort(effort(1.0, 2.0)) is None and block.check_effort(effort(float("nan"))) is None
    assert any("clamped" in line for line in log.lines) and any("dropped" in line for line in log.lines)


def test_the_drives_request_brakes_and_cuts_the_effort_and_its_release_waits_for_the_next():
    block, _ = world()
    block.step(0.01, {"effort": effort(2.0)})
    out = block.step(0.02, {"brake_request": True})
    assert out["brakes"].label == "engaged:requested" and out["true_state"].effort.tolist() == [0.0]
    out = block.step(0.03, {"brake_request": False})
    assert out["brakes"].label == "engaged:" and out["true_state"].effort.tolist() == [0.0]  # cut, not restored


def test_the_estop_ignores_efforts_and_its_release_holds_the_brakes_until_the_drives_next_effort():
    block, log = world()
    block.step(0.01, {"effort": effort(2.0)})
    assert block.take_estop(True)[-1][1].label == "engaged:estop"
    assert block.take_effort(np.array([3.0])) == [] and block.estopped
    assert any("efforts ignored" in line for line in log.lines)
    written = block.take({"estop": False})
    assert [value.label for _, value in written] == ["engaged:", "engaged:drive_timeout"]  # two messages, in order
    assert block.take({"estop": False}) == []  # said again: nothing changes
    assert block.take_effort(np.array([3.0]))[-1][1].label == "engaged:" and block.effort.tolist() == [3.0]


def test_an_estop_that_finds_the_brakes_held_is_said_all_the_same():
    # The drive hears the e-stop first and asks for the brakes (or its efforts stop and the drive timeout brakes):
    # the e-stop coming after must reach the brakes' label, or the run counts its stop as a fault.
    block, _ = world()
    block.step(0.01, {"effort": effort(2.0)})
    assert block.take_brake_request(True)[-1][1].label == "engaged:requested"
    assert block.take_estop(True)[-1][1].label == "engaged:estop,requested"
    assert block.take_brake_request(False)[-1][1].label == "engaged:estop"
    assert block.take_brake_request(False) == [] and block.set_brake("start", False) == []  # nothing changes
    assert block.effort.tolist() == [0.0] and block.estopped


def test_a_disturbance_acts_for_its_duration_and_is_said_once_more_zero_after():
    block, _ = world()
    block.step(0.01, {"effort": effort(0.0)})
    out = block.step(0.02, {"disturbance": effort(5.0, 0.015)})
    assert out["disturbance_applied"].data.tolist() == [5.0, pytest.approx(0.02)]
    assert block.step(0.04, {})["disturbance_applied"].data.tolist() == [0.0, pytest.approx(0.04)]
    assert "disturbance_applied" not in block.step(0.05, {})


def test_the_parameters_disturbance_starts_with_the_first_physics_steps_at_its_start():
    block, log = world(disturbance_torque_nm=[3.0], disturbance_start_s=0.02, disturbance_duration_s=0.5)
    block.step(0.01, {"effort": effort(0.0)})
    assert "disturbance_applied" not in block.step(0.02, {})
    assert block.step(0.03, {})["disturbance_applied"].data[0] == 3.0
    assert any("disturbance started: joint1 3" in line for line in log.lines)


def test_its_physics_is_its_plants_to_the_bit():
    params = cfg.load_stack()["simulator"]
    block, _ = world()
    plant = MujocoPlant(resources.resolve_urdf(params["urdf_path"]), 1.0 / params["physics_rate_hz"])
    plant.reset(np.array(cfg.per_joint("initial_position", params["initial_position"], 1)))
    block.take_effort(np.array([1.5]))
    for k in range(1, 51):
        block.advance(10)
        plant.step(np.array([1.5]), 10)
        assert block.time_ns == k * 10_000_000
    assert block.plant.state()[0].tolist() == plant.state()[0].tolist()
    assert block.sample(0.5)[0][1].position.tolist() == plant.state()[0].tolist()


def test_rates_that_are_no_whole_multiple_are_refused():
    params = cfg.load_stack()["simulator"]
    with pytest.raises(ValueError):  # TimingError: which period, and its ratio
        World.check_params(params | {"physics_rate_hz": 1000.0, "publish_rate_hz": 300.0})


def test_a_plant_given_is_used_as_it_is():
    params = cfg.load_stack()["simulator"]
    plant = MujocoPlant(resources.resolve_urdf(params["urdf_path"]), 1.0 / params["physics_rate_hz"])
    plant.reset(np.array([0.3]))
    block = World(params, Lines(), world_waits=True, plant=plant)
    assert block.plant is plant and block.position().tolist() == [0.3] and block.braked_for("start")
