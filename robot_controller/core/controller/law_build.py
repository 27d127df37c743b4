"""The laws a controller is built with, from its configuration: what a law is told of the arm, the built-in law (the
law in force, or the one a user's law stops on) and a user's law, contained and held to its limits."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from robot_controller.core.controller.config import ControllerConfig
from robot_controller.core.laws import Arm, BuiltinLaw, ContainedLaw, registry
from robot_controller.core.model import ArmDynamics
from robot_controller.core.model.mujoco_model import position_ranges


def arm_of(config: ControllerConfig, dynamics: ArmDynamics | None, joint_count: int) -> Arm:
    """What a law is told about the arm: the controller's model of it (None: no model) and its limits."""
    model = getattr(dynamics, "model", None)  # a MuJoCo model knows the joints' ranges
    limits = np.tile([-np.inf, np.inf], (joint_count, 1)) if model is None else position_ranges(model)[:joint_count]
    names = tuple(dynamics.joint_names if dynamics is not None else (f"joint {j + 1}" for j in range(joint_count)))
    return Arm(dynamics, names, np.array(config.pid.output_limit, dtype=float), limits)


def builtin_law(config: ControllerConfig, arm: Arm) -> BuiltinLaw:
    law_class = registry.resolve(config.builtin_law)  # pid or lqr, by their entry points
    return law_class(arm, config.control_period_s, config.law_params())


def plugin_law(
    config: ControllerConfig,
    arm: Arm,
    law_clock: Callable[[], float] | None,
    law_run_wait: Callable[[], float] | None,
) -> ContainedLaw:
    law = ContainedLaw.build(
        config.controller_type, arm, config.control_period_s, config.law_parameters, law_clock, law_run_wait
    )
    hold_to_limits(law, config)
    return law


def hold_to_limits(law: ContainedLaw, c: ControllerConfig) -> None:
    limits = (c.law_budget_s, c.law_error_max_rad, c.stop_deceleration)
    law.set_limits(c.pid.output_limit, c.pid.slew_rate_limit, *limits)
