"""Exercise 4, "Switch to LQR": the tutorial's PID against an LQR in the same plumbing (and, in the
full form, the default stack's LQR): gains, closed-loop poles and margins, the sine and a step."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.core.laws import robustness
from robot_controller.experiments.compare import Contender
from robot_controller.experiments.exercises.lqr_report import plot, report_text
from robot_controller.experiments.loop_model import law_gains, plant_loop
from robot_controller.experiments.reporting import Progress, write_report, write_results
from robot_controller.experiments.runs import SEED, Response, sine_params, sine_run, step_run, store

STEP_RAD = 0.5


LQR = {"controller_type": "lqr"}
CONTENDERS = (
    Contender("pid", "the tutorial's PID as written", "tutorial", {}),
    Contender("lqr", "LQR in the tutorial's plumbing (no feedforward, no Kalman filter)", "tutorial", LQR),
    Contender("lqr_default", "LQR as the default stack runs it (feedforward, Kalman filter)", "default", LQR),
)


def _plan(quick: bool) -> dict[str, Any]:
    if quick:
        return {"contenders": CONTENDERS[:2], "sine_s": 3.0, "after_s": 1.5}
    return {"contenders": CONTENDERS, "sine_s": 10.0, "after_s": 2.0}


def steps(quick: bool = False) -> int:
    return 2 * len(_plan(quick)["contenders"])


def loop_analysis(params: cfg.Params) -> dict[str, Any]:
    """The gains in force (an LQR's designed), the sampled loop's closed-loop poles under them and its margins."""
    gains = law_gains(params)
    A, B, dt = plant_loop(params)
    kp, ki, kd = float(gains.kp[0]), float(gains.ki[0]), float(gains.kd[0])
    K = robustness.pid_gain_row(kp, ki, kd)
    return {
        "kp": kp,
        "ki": ki,
        "kd": kd,
        "derivative_source": gains.derivative_source.value,
        "dt": dt,
        "poles": robustness.poles(A, B, K),
        "margins": robustness.margins(A, B, K, dt),
        "delay_margin_periods": int(robustness.delay_margin_periods(A, B, K)[0]),
    }


def run(out: Path, *, quick: bool = False, progress: Progress = print, seed: int = SEED) -> dict[str, Any]:
    out.mkdir(parents=True, exist_ok=True)
    plan = _plan(quick)
    results: dict[str, Any] = {"quick": int(quick), "seed": seed, "step_rad": STEP_RAD}
    steps_run: list[Response] = []
    sines: list[Response] = []
    analyses: dict[str, dict[str, Any]] = {}
    for contender in plan["contenders"]:
        params = contender.params()
        analysis = loop_analysis(params)
        analyses[contender.name] = analysis
        name = contender.name
        margins = analysis["margins"]
        store(results, name, analysis, ("kp", "ki", "kd"))
        results[f"{name}_spectral_radius"] = float(np.max(np.abs(analysis["poles"])))
        results[f"{name}_gain_margin_db"] = margins.gain_margin_db
        results[f"{name}_phase_margin_deg"] = margins.phase_margin_deg
        results[f"{name}_delay_margin_periods"] = analysis["delay_margin_periods"]
        for index, pole in enumerate(analysis["poles"]):
            results[f"{name}_pole_{index + 1}_re"] = float(pole.real)
            results[f"{name}_pole_{index + 1}_im"] = float(pole.imag)
            results[f"{name}_pole_{index + 1}_abs"] = float(abs(pole))
        progress(f"{name}: sine")
        sine = sine_run(sine_params(params), out / name / "sine", name, duration_s=plan["sine_s"], seed=seed)
        sines.append(sine)
        store(results, f"{name}_sine", sine.figures, ("tracking_rms_rad", "tracking_max_rad", "peak_torque_nm"))
        progress(f"{name}: step")
        step = step_run(params, out / name / "step", name, amplitude=STEP_RAD, after_s=plan["after_s"], seed=seed)
        steps_run.append(step)
        keys = "overshoot_pct settling_time_s rise_time_s steady_state_error_rad peak_torque_nm saturated_s"
        store(results, f"{name}_step", step.figures, keys.split())
    results = write_results(out, results)
    plot(out / "lqr.png", steps_run, sines, analyses, STEP_RAD)
    write_report(out, report_text(results, plan, analyses, quick))
    return results
