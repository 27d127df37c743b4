"""``run --hardware``: what a run on a robot is given, and what it refuses in one line before anything starts."""

import pytest

from robot_controller.core.errors import ConfigError
from robot_controller.runner.options import RunOptions
from robot_controller.runner.plan import check


@pytest.mark.parametrize(
    ("options", "said"),
    [
        (RunOptions(robot="panda", hardware="franka://127.0.0.1", sim_time=True), "--sim-time needs the simulator"),
        (RunOptions(robot="panda", hardware="franka://127.0.0.1", respawn=True), "--respawn needs the simulator"),
        (RunOptions(hardware="franka://127.0.0.1"), "a Franka arm is --robot panda, not one_dof"),
        (RunOptions(robot="panda", hardware="franka://host:99"), "only a host"),
        (RunOptions(robot="panda", hardware="ur5://host"), "franka://HOST"),
    ],
)
def test_what_a_robot_cannot_do_is_refused_before_it_is_reached(options, said):
    with pytest.raises(ConfigError, match=said):
        check(options.params(), options)


def test_a_planner_that_would_ignore_the_limits_is_refused_on_a_robot(tmp_path):
    config = tmp_path / "ignore.yaml"
    config.write_text("trajectory_planner:\n  ros__parameters:\n    feasibility: ignore\n")
    options = RunOptions(robot="panda", hardware="franka://127.0.0.1", config=(config,))
    with pytest.raises(ConfigError, match="feasibility ignore would send a robot past its limits"):
        check(options.params(), options)


def test_an_unreachable_robot_is_one_line():
    pytest.importorskip("pylibfranka", reason="the franka extra: pip install -e '.[dev]'")
    options = RunOptions(robot="panda", hardware="franka://127.0.0.2")  # nothing serves libfranka there
    with pytest.raises(ConfigError, match="cannot reach the Franka at 127.0.0.2"):
        check(options.params(), options)
