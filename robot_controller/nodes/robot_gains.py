"""The controller's parameters on a robot (``run --hardware``): a node named ``pid_controller``, as in simulation, so
``param set pid_controller kp …`` works the same. It runs in the drive's ROS side (``robot_node``); a change is
checked here (the law designed, its delay margin found, as the simulated controller does) and handed to the drive,
which takes it at its next tick. What a robot fixes (its rate, a law of one's own) is refused with the reason."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from robot_controller import parameters as cfg
from robot_controller.core.controller import ControllerConfig
from robot_controller.core.errors import ConfigError
from robot_controller.nodes.live_gains import Designer
from robot_controller.parameters.builders import arm_model
from robot_controller.ros.adapter import BlockNode, Extras

NODE_NAME = "pid_controller"


class DriveGains:
    """A block with no ports: the controller's parameters, checked and sent on (``send``) to the drive."""

    inputs: tuple[str, ...] = ()
    outputs: tuple[str, ...] = ()

    def __init__(self, params: Mapping[str, Any], send: Callable[[ControllerConfig, int | None], None]) -> None:
        self.dynamics = arm_model(params)
        self.joint_count = len(self.dynamics.joint_names)
        self.send = send
        # Designed in a worker process, as the simulated controller's changes are: a design holds this interpreter
        # for about a second on the Panda, and the planner's samples must go on reaching the drive meanwhile (held
        # up, the controller took the planner for lost and stopped the arm).
        self.designer = Designer(arm_model(params), self.joint_count)
        self.fixed = {"control_rate_hz": params["control_rate_hz"], "controller_type": params["controller_type"]}
        self.checked: tuple[ControllerConfig, int | None] | None = None

    def check_params(self, params: Mapping[str, Any]) -> None:
        for name, value in self.fixed.items():
            if params[name] != value:
                raise ConfigError(f"{name}: on a robot it is fixed at the start ({value!r}): restart the run")
        config = cfg.controller_config(params, self.joint_count)
        # Refuses a design that does not stabilise, or leaves less than min_delay_margin_periods.
        self.checked = config, self.designer.margin(config)

    def set_params(self, params: Mapping[str, Any], changed: set[str]) -> None:
        if self.checked is not None:
            self.send(*self.checked)

    def start(self) -> dict[str, Any]:
        return {}

    def wake_period_s(self) -> float | None:
        return None


class _Still:
    """No clock: the block only checks parameters."""

    def start(self) -> None:
        pass


def gains_node(send: Callable[[ControllerConfig, int | None], None]) -> BlockNode:
    """The node, its parameters those the run started the controller with."""

    class GainsExtras(Extras):
        def make_block(self, params: dict[str, Any], world_waits: bool) -> DriveGains:
            return DriveGains(params, send)

        def make_ticks(self, source: type) -> _Still:
            return _Still()

        def destroy(self) -> None:
            self.node.block.designer.stop()

    return BlockNode(NODE_NAME, GainsExtras)
