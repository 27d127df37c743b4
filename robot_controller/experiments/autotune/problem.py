"""The tuning problem: the configured arm and controller as the search sees
them, what is searched (Kp, Ki, Kd for ``pid``; the state weights ``lqr_q`` for
``lqr``) and how it maps to gains and to a parameter overlay, and the
objective: the sine's tracking RMS on the in-process batch harness
(``core.batch``, common random numbers)."""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.batch import ArmConstants, run_batch
from robot_controller.core.errors import ConfigError
from robot_controller.core.laws import lqr
from robot_controller.core.laws.pid import PidConfig
from robot_controller.core.model import ArmDynamics, SensorConfig
from robot_controller.core.reference import Trajectory, make_trajectory

SEED = 0

#: The search box, log10 of each parameter. PID: Kp N·m/rad, Ki N·m/(rad·s), Kd N·m·s/rad.
PID_BOX = {"kp": (0.0, 3.5), "ki": (-1.0, 3.5), "kd": (-2.0, 1.7)}
#: LQR: the weights on ∫e, e and ė (lqr_r fixed).
LQR_BOX = {"q_integral": (-1.0, 8.0), "q_position": (0.0, 8.0), "q_velocity": (-4.0, 5.0)}


class Problem:
    """The configured arm and controller, as the search sees them."""

    def __init__(self, params: cfg.Params) -> None:
        from robot_controller.experiments.exercises.common import controller_model, law_gains, plant_loop

        self.params = params
        ctrl, motor = params["pid_controller"], params["motor_node"]
        self.controller_type = ctrl["controller_type"]
        self.dt = 1.0 / ctrl["control_rate_hz"]
        self.A, self.B, _ = plant_loop(params)
        self.law = law_gains(params)  # the PID settings in force (for an LQR: with its designed gains)
        plant = ArmDynamics(resources.resolve_urdf(params["simulator"]["urdf_path"]))
        self.constants = ArmConstants.from_dynamics(plant)
        model = controller_model(params)  # what the controller designs an LQR with
        self.model_inertia = float(model.mass_matrix(np.zeros(1))[0, 0])
        self.model_damping = float(model.damping[0])
        self.torque_max = float(min(np.min(ctrl["torque_max"]), np.min(motor["torque_max"])))
        self.feedforward = ctrl["feedforward"]
        self.kalman = cfg.controller_config(ctrl, 1).estimator  # None without the filter
        self.lqr_r = float(ctrl["lqr_r"])
        planner = params["trajectory_planner"]
        self.sine = make_trajectory(
            "sine",
            joint_count=1,
            amplitude=planner["amplitude"],
            frequency_hz=planner["frequency_hz"],
            offset=planner["offset"],
        )
        self.sensor = cfg.sensor_config(params["sensor_node"])
        self.box = PID_BOX if self.controller_type == "pid" else LQR_BOX

    # -- what is searched -> the gains
    def gains_of(self, log_params: np.ndarray) -> np.ndarray:
        """Kp, Ki, Kd of each row of searched parameters, log10 (NaN where an LQR design fails)."""
        return self.gains_of_values(10.0 ** np.atleast_2d(log_params))

    def gains_of_values(self, values: np.ndarray) -> np.ndarray:
        """Kp, Ki, Kd of each row of searched parameters (NaN where an LQR design fails)."""
        values = np.atleast_2d(np.asarray(values, dtype=float))
        if self.controller_type == "pid":
            return values[:, [0, 1, 2]].copy()
        out = np.full((len(values), 3), np.nan)
        for row, q in enumerate(values):
            try:
                K = lqr.design(self.model_inertia, self.model_damping, self.dt, q, self.lqr_r).K[0]
            except (ConfigError, ValueError, np.linalg.LinAlgError):
                continue
            out[row] = (K[1], K[0], K[2])
        return out

    def current_log_params(self) -> np.ndarray:
        ctrl = self.params["pid_controller"]
        if self.controller_type == "pid":
            values = [ctrl["kp"][0], ctrl["ki"][0], ctrl["kd"][0]]
        else:
            values = list(ctrl["lqr_q"])
        return np.log10(np.maximum(np.asarray(values, dtype=float), 1e-12))

    @staticmethod
    def rounded(log_params: np.ndarray) -> np.ndarray:
        """The searched parameters, to 4 significant figures (as the parameter file gets them)."""
        return np.array([_round(v) for v in 10.0 ** np.asarray(log_params, dtype=float)])

    def overlay(self, values: np.ndarray) -> dict[str, Any]:
        """The ``pid_controller`` parameters that set these searched parameters."""
        values = [float(v) for v in values]
        if self.controller_type == "pid":
            return {"kp": [values[0]], "ki": [values[1]], "kd": [values[2]]}
        return {"lqr_q": values, "lqr_r": self.lqr_r}

    # -- the objective
    def tracking_rms(self, gains: np.ndarray, duration_s: float, seed: int = SEED) -> np.ndarray:
        """The sine's tracking RMS (true angle, after the 2 s warm-up) of each gain set (rows Kp, Ki, Kd), rad."""
        pid = replace(self.law, kp=gains[:, 0:1], ki=gains[:, 1:2], kd=gains[:, 2:3])
        return batch_tracking_rms(
            self.constants,
            pid,
            self.sine,
            self.sensor,
            np.random.default_rng(seed),
            duration_s=duration_s,
            control_period_s=self.dt,
            torque_max=self.torque_max,
            feedforward=self.feedforward,
            kalman=self.kalman,
        )


def batch_tracking_rms(
    constants: ArmConstants,
    pid_config: PidConfig,
    trajectory: Trajectory,
    sensor: SensorConfig,
    rng: np.random.Generator,
    *,
    common_noise: bool = True,
    **options: Any,
) -> np.ndarray:
    """The search's harness: ``core.batch.run_batch`` with common random numbers by default."""
    return run_batch(
        constants=constants,
        pid_config=pid_config,
        trajectory=trajectory,
        sensor=sensor,
        rng=rng,
        common_noise=common_noise,
        **options,
    )


def _round(value: float, digits: int = 4) -> float:
    if value == 0 or not math.isfinite(value):
        return float(value)
    return float(round(value, digits - 1 - int(math.floor(math.log10(abs(value))))))
