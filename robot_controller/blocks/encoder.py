"""The encoder (the graph's ``sensor_node``): samples the true state on a ``rate_hz`` grid of its stamps, adds seeded
noise (and ``delay_s``) and writes the reading stamped with the sample's time; once at start, the arm's URDF (as
robot_state_publisher does), for ROS clients such as MoveIt."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.blocks.block import Log
from robot_controller.blocks.values import JointSample, check_joint_state
from robot_controller.core.model import DelayLine, load_model, measure
from robot_controller.core.model.mujoco_model import joint_units

# Stamps within this of a grid point count as on it (float ns rounding).
_GRID_EPS_S = 1e-6
# A stamp this far before the sampling grid restarts it (a future-stamped message may have set the grid).
RESYNC_S = 1.0


class Encoder:
    inputs = ("true_state",)
    outputs = ("reading", "robot_description")

    def __init__(self, params: Mapping[str, Any], log: Log, *, world_waits: bool = False) -> None:
        self.log = log
        seed = params["seed"]
        self.rng = np.random.default_rng(None if seed < 0 else seed)
        self.sensor = cfg.sensor_config(params)
        self.delay_line = DelayLine(self.sensor.delay_s)
        self.period_s = 1.0 / params["rate_hz"]
        self.next_sample_s: float | None = None
        self.joint_names: list[str] | None = None
        self.urdf = resources.resolve_urdf(params["urdf_path"])
        units = " or ".join(dict.fromkeys(joint_units(load_model(self.urdf))))
        log.info(
            f"sensor at {params['rate_hz']:g} Hz: σ position {self.sensor.position_noise_std:g} {units}, "
            f"σ velocity {self.sensor.velocity_noise_std:g} {units.replace('rad', 'rad/s').replace('m', 'm/s')}, "
            f"seed {seed}" + (f", {self.sensor.delay_s * 1e3:g} ms late" if self.sensor.delay_s else "")
        )

    def start(self) -> dict[str, Any]:
        return {"robot_description": self.urdf.read_text()}

    def wake_period_s(self) -> float | None:
        return None

    def check_params(self, params: Mapping[str, Any]) -> None:
        cfg.sensor_config(params)

    def set_params(self, params: Mapping[str, Any], changed: set[str]) -> None:
        self.sensor = cfg.sensor_config(params)
        self.delay_line.delay_s = self.sensor.delay_s
        self.period_s = 1.0 / params["rate_hz"]

    def step(self, t_s: float, inputs: Mapping[str, Any]) -> dict[str, Any]:
        state: JointSample | None = inputs.get("true_state")
        if state is None:
            return {}
        stamp_s = state.stamp_s
        if self.next_sample_s is not None and stamp_s < self.next_sample_s - _GRID_EPS_S:
            if stamp_s > self.next_sample_s - self.period_s - RESYNC_S:
                return {}  # between samples
            # Far behind: a bogus (far-future) stamp set the grid, or the simulator restarted: follow the stamps.
            behind_s = self.next_sample_s - stamp_s
            self.log.warn(
                "resync",
                f"true state stamp {stamp_s:.3f} s is {behind_s:.3f} s behind the sampling grid: re-synchronised",
            )
        if self.joint_names is None:
            self.joint_names = state.names  # the world's own list: the same object every time, compared at once
        checked = check_joint_state(state.names, state.position, state.velocity, self.joint_names)
        if isinstance(checked, str):
            self.log.warn("true_state", f"true state unusable: {checked}")
            return {}
        # Next grid point after this stamp (skips ahead if the world published sparsely). A Python float, as the
        # stamps are: numpy's scalars cost more in each step's comparisons.
        self.next_sample_s = (math.floor((stamp_s + _GRID_EPS_S) / self.period_s) + 1) * self.period_s
        position, velocity = checked
        if self.sensor.delay_s > 0:
            stamp_s, position, velocity = self.delay_line.push(stamp_s, position, velocity)
        position, velocity = measure(self.sensor, position, velocity, self.rng)
        return {"reading": JointSample(stamp_s, self.joint_names, position, velocity)}
