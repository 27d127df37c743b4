"""``tune`` of the LQR on a chain of joints: each joint's torque weight ``lqr_r`` chosen on its own, from a target the
user reads (``tracking``, ``effort``, ``robust``), each joint held to its delay margin (through the filter and the
disturbance observer, as the controller judges it at start) and to the torque its feedback makes of the sensor's noise.
The design is then verified on the real graph over several seeds (:mod:`.verification`)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.core.controller.config import law_config
from robot_controller.core.controller.supervision import joint_delay_margins
from robot_controller.core.errors import ConfigError
from robot_controller.parameters.builders import arm_model
from robot_controller.parameters.spec import per_joint
from robot_controller.parameters.torque_limits import torque_limit

#: What each target asks of every joint: control periods of delay margin it keeps, the share of its torque limit its
#: feedback may make of the sensor's noise, and how much slower than the fastest such design it is made (the
#: torque weight's factor: 16 halves an LQR's bandwidth on a double integrator).
TARGETS: dict[str, tuple[int, float, float]] = {
    "tracking": (2, 0.05, 1.0),
    "robust": (4, 0.025, 1.0),
    "effort": (3, 0.025, 16.0),
}
TARGET_TEXT = {
    "tracking": "the fastest feedback each joint keeps 2 control periods of delay margin with",
    "robust": "the fastest feedback each joint keeps 4 control periods of delay margin with",
    "effort": "half the bandwidth of the fastest feedback with 3 periods of delay margin: less torque and noise",
}
#: The torque weights tried on each joint: quarter decades about the one in force.
DECADES_BELOW, DECADES_ABOVE, PER_DECADE = 6, 4, 4


@dataclass(frozen=True)
class JointDesign:
    name: str
    lqr_r: float  #: the weight chosen (before the reference_inertia scaling every lqr_r takes)
    kp: float  #: N·m/rad, the design's
    kd: float  #: N·m·s/rad
    delay_margin_periods: int
    noise_torque_nm: float  #: Kp·σ_q + Kd·σ_v of the sensor's noise
    torque_limit_nm: float
    in_force_r: float
    in_force_margin_periods: int
    found: bool  #: False: no weight tried meets the target; the one in force is kept


def design_joints(params: cfg.Params, target: str) -> list[JointDesign]:
    """Each joint's torque weight for ``target`` (one of ``TARGETS``), every other joint at the weight in force."""
    if target not in TARGETS:
        raise ConfigError(f"--target {target}: expected one of {', '.join(TARGETS)}")
    margin_needed, noise_share, slower = TARGETS[target]
    ctrl = params["pid_controller"]
    dynamics = arm_model(ctrl)
    n = len(dynamics.joint_names)
    config = cfg.controller_config(ctrl, n)
    in_force = per_joint("lqr_r", ctrl["lqr_r"], n)
    limit = np.minimum(torque_limit(ctrl, n), torque_limit(params["motor_node"], n))
    sensor = params["sensor_node"]
    noise = np.array([sensor["position_noise_std"], sensor["velocity_noise_std"]], dtype=float)
    in_force_margins = joint_delay_margins(law_config(config, dynamics, n), dynamics, n, config)
    designs = []
    for j, name in enumerate(dynamics.joint_names):
        exponents = np.arange(-DECADES_BELOW * PER_DECADE, DECADES_ABOVE * PER_DECADE + 1) / PER_DECADE
        chosen = None
        for weight in in_force[j] * 10.0**exponents:  # the fastest first
            figures = _joint_figures(config, dynamics, n, in_force, j, float(weight), noise)
            if figures[2] >= margin_needed and figures[3] <= noise_share * limit[j]:
                chosen = float(weight) * slower
                break
        weight = in_force[j] if chosen is None else chosen
        kp, kd, margin, noise_nm = _joint_figures(config, dynamics, n, in_force, j, float(weight), noise)
        designs.append(
            JointDesign(
                name, float(weight), kp, kd, margin, noise_nm, float(limit[j]), float(in_force[j]),
                int(in_force_margins[j]), chosen is not None,
            )
        )  # fmt: skip
    return designs


def _joint_figures(
    config: Any, dynamics: Any, n: int, weights: np.ndarray, j: int, weight: float, noise: np.ndarray
) -> tuple[float, float, int, float]:
    """Joint ``j``'s Kp, Kd, delay margin (periods) and noise torque with torque weight ``weight``."""
    trial = weights.copy()
    trial[j] = weight
    trial_config = replace(config, lqr_r=tuple(trial.tolist()))
    gains = law_config(trial_config, dynamics, n)
    margin = joint_delay_margins(gains, dynamics, n, trial_config, joints=[j])[0]
    kp, kd = float(gains.kp[j]), float(gains.kd[j])
    return kp, kd, int(margin), kp * noise[0] + kd * noise[1]


def in_force(params: cfg.Params, designs: list[JointDesign]) -> bool:
    """Whether the design is the configuration in force: the LQR, each joint at the weight it has."""
    same = all(d.lqr_r == d.in_force_r for d in designs)
    return same and params["pid_controller"]["controller_type"] == "lqr"


def overlay(designs: list[JointDesign]) -> dict[str, Any]:
    """The controller's parameters the design sets: the law and each joint's torque weight."""
    return {"controller_type": "lqr", "lqr_r": [float(f"{d.lqr_r:.4g}") for d in designs]}


def design_lines(designs: list[JointDesign]) -> list[str]:
    """One line per joint: the weight and gains chosen against the ones in force, or why none was found."""
    lines = []
    for d in designs:
        if not d.found:
            lines.append(f"{d.name}: no torque weight meets the target; the one in force ({d.in_force_r:.3g}) is kept")
            continue
        lines.append(
            f"{d.name}: lqr_r {d.in_force_r:.3g} → {d.lqr_r:.3g}: Kp {d.kp:.3g} N·m/rad, Kd {d.kd:.3g} N·m·s/rad, "
            f"delay margin {d.delay_margin_periods} periods (was {d.in_force_margin_periods}), noise torque "
            f"{d.noise_torque_nm:.3g} N·m of {d.torque_limit_nm:.3g}"
        )
    return lines
