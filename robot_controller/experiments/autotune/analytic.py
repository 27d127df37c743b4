"""``tune`` of a built-in law (``pid``: Kp, Ki, Kd; ``lqr``: the weights ``lqr_q``, ``lqr_r`` kept): the
search runs on the batch harness (``core.batch``, common random numbers) after screening every gain set by
the sampled loop's margins, then one seeded sine run on sim time before and one after on the real graph."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.batch import run_batch
from robot_controller.core.errors import ConfigError
from robot_controller.core.laws import lqr
from robot_controller.core.model import ArmDynamics, JointArmModel
from robot_controller.core.reference import make_trajectory
from robot_controller.experiments.autotune.margins import (
    MIN_DELAY_PERIODS,
    MIN_GAIN_MARGIN_DB,
    MIN_PHASE_MARGIN_DEG,
    describe_margins,
    screen,
)
from robot_controller.experiments.autotune.search import FAILED, ROBUST, SEED, SearchPlan, SearchResult
from robot_controller.experiments.loop_model import law_gains, plant_loop
from robot_controller.experiments.step import run_sim_time
from robot_controller.parameters.builders import arm_model

#: The search box, log10 of each parameter. PID: Kp N·m/rad, Ki N·m/(rad·s), Kd N·m·s/rad.
PID_BOX = {"kp": (0.0, 3.5), "ki": (-1.0, 3.5), "kd": (-2.0, 1.7)}
#: LQR: the weights on ∫e, e and ė (lqr_r fixed).
LQR_BOX = {"q_integral": (-1.0, 8.0), "q_position": (0.0, 8.0), "q_velocity": (-4.0, 5.0)}


class AnalyticProblem:
    """The configured arm and built-in law, as the search sees them (coordinates: log10 of the searched values)."""

    centres = 8
    check_steps = 2  #: progress steps after the search: the real runs before and after

    def __init__(self, params: cfg.Params) -> None:
        self.params = params
        ctrl, motor = params["pid_controller"], params["motor_node"]
        self.controller_type = ctrl["controller_type"]
        self.dt = 1.0 / ctrl["control_rate_hz"]
        self.A, self.B, _ = plant_loop(params)
        self.law = law_gains(params)  # the PID settings in force (for an LQR: with its designed gains)
        plant = ArmDynamics(resources.resolve_urdf(params["simulator"]["urdf_path"]))
        self.arm_model = JointArmModel.over_urdf(plant)
        model = arm_model(ctrl)  # what the controller designs an LQR with
        self.model_inertia = float(model.mass_matrix(np.zeros(1))[0, 0])
        self.model_damping = float(model.damping[0])
        self.torque_max = float(min(np.min(ctrl["torque_max"]), np.min(motor["torque_max"])))
        self.feedforward = ctrl["feedforward"]
        self.kalman = cfg.controller_config(ctrl, 1).estimator  # None without the filter
        self.lqr_r = float(np.atleast_1d(ctrl["lqr_r"])[0])  # one joint
        planner = params["trajectory_planner"]
        sine = {key: planner[key] for key in ("amplitude", "frequency_hz", "offset")}
        self.sine = make_trajectory("sine", joint_count=1, **sine)
        self.sensor = cfg.sensor_config(params["sensor_node"])
        self.box = PID_BOX if self.controller_type == "pid" else LQR_BOX
        self.low = np.array([b[0] for b in self.box.values()])
        self.high = np.array([b[1] for b in self.box.values()])
        self.clip_low, self.clip_high = self.low - 1.0, self.high + 1.0

    @staticmethod
    def plan(quick: bool) -> SearchPlan:
        if quick:
            return SearchPlan(first=2048, rounds=((256, 0.25), (256, 0.1)), duration_s=4.0, check_s=3.0)
        return SearchPlan(
            first=8192, rounds=((1024, 0.3), (1024, 0.15), (1024, 0.07), (1024, 0.03)), duration_s=10.0, check_s=10.0
        )

    def round_text(self, samples: int, spread: float | None) -> str:
        return f"{samples} gain sets" + ("" if spread is None else f" within ±{spread:g} decades of the best")

    @staticmethod
    def values(points: np.ndarray) -> np.ndarray:
        return 10.0 ** np.atleast_2d(points)

    def evaluate(
        self, values: np.ndarray, plan: SearchPlan, seed: int, best_rms: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Screen every gain set by its margins; simulate those that meet them."""
        gains = self.gains_of_values(values)
        _, ok = screen(self, gains)
        rms = np.full(len(values), np.inf)
        if np.any(ok):
            rms[ok] = self.tracking_rms(gains[ok], plan.duration_s, seed)
        return rms, np.where(ok, ROBUST, FAILED), gains

    def passes(self, values: np.ndarray, seed: int) -> bool:
        return bool(screen(self, self.gains_of_values(values))[1][0])

    def nothing_robust(self) -> str:
        return (
            "tune: no gain set in the search met the margins "
            f"(gain ≥ {MIN_GAIN_MARGIN_DB:g} dB, phase ≥ {MIN_PHASE_MARGIN_DEG:g}°, delay ≥ "
            f"{MIN_DELAY_PERIODS} periods)"
        )

    # -- what is searched -> the gains
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

    def before_gains(self) -> np.ndarray:
        """Kp, Ki, Kd in force (an LQR's designed)."""
        return np.array([self.law.kp[0], self.law.ki[0], self.law.kd[0]], dtype=float)

    def start(self) -> np.ndarray:
        """The configured values' search coordinates."""
        ctrl = self.params["pid_controller"]
        if self.controller_type == "pid":
            values = [ctrl["kp"][0], ctrl["ki"][0], ctrl["kd"][0]]
        else:
            values = list(ctrl["lqr_q"])
        return np.log10(np.maximum(np.asarray(values, dtype=float), 1e-12))

    def overlay(self, values: np.ndarray) -> dict[str, Any]:
        """The ``pid_controller`` parameters that set these searched parameters."""
        values = [float(v) for v in values]
        if self.controller_type == "pid":
            return {"kp": [values[0]], "ki": [values[1]], "kd": [values[2]]}
        return {"lqr_q": values, "lqr_r": self.lqr_r}

    tuned_overlay = overlay

    # -- the objective
    def tracking_rms(self, gains: np.ndarray, duration_s: float, seed: int = SEED) -> np.ndarray:
        """The sine's tracking RMS (true angle, after the 2 s warm-up) of each gain set (rows Kp, Ki, Kd), rad."""
        pid = replace(self.law, kp=gains[:, 0:1], ki=gains[:, 1:2], kd=gains[:, 2:3])
        harness = {"trajectory": self.sine, "sensor": self.sensor, "duration_s": duration_s, "kalman": self.kalman}
        harness.update(control_period_s=self.dt, torque_max=self.torque_max, feedforward=self.feedforward)
        rng = np.random.default_rng(seed)  # common random numbers: every gain set meets the same noise
        return run_batch(model=self.arm_model, pid_config=pid, rng=rng, common_noise=True, **harness)


def before_after(
    problem: AnalyticProblem,
    result: SearchResult,
    plan: SearchPlan,
    *,
    seed: int,
    out: Path,
    progress: Callable[[str], None],
) -> dict[str, Any]:
    """``tune.json``'s figures: each margin and the batch RMS before and after, and one
    seeded sine run on sim time each on the real graph (in ``out/real_before``, ``out/real_after``)."""
    before_gains, after_gains = problem.before_gains(), problem.gains_of_values(result.best_values)[0]
    batch = problem.tracking_rms(np.vstack([before_gains, after_gains]), plan.duration_s, seed)
    values: dict[str, Any] = {
        "controller_type_lqr": int(problem.controller_type == "lqr"),
        "batch_duration_s": plan.duration_s,
        "min_gain_margin_db": MIN_GAIN_MARGIN_DB,
        "min_phase_margin_deg": MIN_PHASE_MARGIN_DEG,
        "min_delay_margin_periods": MIN_DELAY_PERIODS,
    }
    for name, gains, searched in (
        ("before", before_gains, 10.0 ** problem.start()),
        ("after", after_gains, result.best_values),
    ):
        values.update({f"{name}_kp": gains[0], f"{name}_ki": gains[1], f"{name}_kd": gains[2]})
        if problem.controller_type == "lqr":
            for key, value in zip(("q_integral", "q_position", "q_velocity"), searched, strict=True):
                values[f"{name}_lqr_{key}"] = float(value)
            values[f"{name}_lqr_r"] = problem.lqr_r
        for key, value in describe_margins(problem, gains).items():
            values[f"{name}_{key}"] = value
    values["batch_rms_before_rad"], values["batch_rms_after_rad"] = (float(v) for v in batch)
    tuned = cfg.merge(problem.params, {"pid_controller": problem.overlay(result.best_values)})
    for name, run_params in (("before", problem.params), ("after", tuned)):
        progress(f"real graph, {name}: {plan.check_s:g} s sine on sim time")
        seeded = cfg.merge(run_params, {"sensor_node": {"seed": seed}})
        figures, _ = run_sim_time(seeded, out / f"real_{name}", plan.check_s)
        values[f"real_rms_{name}_rad"] = figures["tracking_rms_rad"]
        values[f"real_max_{name}_rad"] = figures["tracking_max_rad"]
        values[f"real_peak_torque_{name}_nm"] = figures["peak_torque_nm"]
    values["real_duration_s"] = plan.check_s
    return values
