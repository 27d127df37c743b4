"""The loop's linear model, for margins and designs: the simulated arm's joint linearised at rest and
sampled at the control period, the arm model the controller designs with, the gains in force."""

from __future__ import annotations

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.controller.config import law_config
from robot_controller.core.laws import lqr
from robot_controller.core.model import ArmDynamics
from robot_controller.parameters.builders import arm_model


def plant_loop(params: cfg.Params) -> tuple[np.ndarray, np.ndarray, float]:
    """The joint linearised at rest, sampled at the control period (state ``[∫e, e, ė]``): ``A``, ``B``, ``dt``."""
    dynamics = ArmDynamics(resources.resolve_urdf(params["simulator"]["urdf_path"]))
    dt = 1.0 / params["pid_controller"]["control_rate_hz"]
    A, B = lqr.discretise(float(dynamics.mass_matrix(np.zeros(1))[0, 0]), float(dynamics.damping[0]), dt)
    return A, B, dt


def law_gains(params: cfg.Params):
    """The PID settings the controller runs with (for an LQR, its designed gains on the controller's own arm model:
    the URDF's, or its ``model_*`` parameters over it)."""
    return law_config(cfg.controller_config(params["pid_controller"], 1), arm_model(params["pid_controller"]), 1)
