"""Exercise 1's numbers: the tutorial's gains, the steps, the thresholds, and each form's runs."""

from __future__ import annotations

from typing import Any

from robot_controller import parameters as cfg

PRESET = "tutorial"
KP_START = 50.0  #: the tutorial's starting point, N·m/rad
KU_STEP_RAD = 0.2  #: the Kp search's step: small, so the oscillation stays inside the torque limit at first
STAGE_STEP_RAD = 0.5  #: the Kd and Ki stages' step
STAGE_LEAD_S = 1.0  #: at rest before the step (the arm sags under gravity first: no feedforward)
SUSTAINED_GROWTH_PER_S = -0.02  #: an amplitude shrinking slower than 2 %/s is not decaying
NOISE_FLOOR_RAD = 0.005  #: an oscillation smaller than this (the sensor's σ) is no oscillation
OVERSHOOT_MAX_PCT = 2.0  #: "overshoot gone" (the tutorial's "< 2 %")
SSE_MAX_FRACTION = 0.01  #: "steady-state error gone": within 1 % of the step
TUTORIAL_GAINS = (50.0, 10.0, 5.0)


def make_plan(quick: bool) -> dict[str, Any]:
    if quick:
        return {
            "ku_runs": 3,
            "ku_after_s": 2.5,
            "kd_factors": (4.0,),
            "ti_tu": (4.0,),
            "stage_after_s": 1.5,
            "sine_s": 3.0,
            "zn_run": False,
            "tutorial_runs": False,
        }
    return {
        "ku_runs": 8,
        "ku_after_s": 4.0,
        "kd_factors": (1.0, 2.0, 4.0, 8.0),
        "ti_tu": (8.0, 4.0, 2.0, 1.0),
        "stage_after_s": 2.0,
        "sine_s": 10.0,
        "zn_run": True,
        "tutorial_runs": True,
    }


def steps(quick: bool = False) -> int:
    p = make_plan(quick)
    return p["ku_runs"] + int(p["zn_run"]) + len(p["kd_factors"]) + len(p["ti_tu"]) + 1 + 2 * int(p["tutorial_runs"])


def with_gains(params: cfg.Params, kp: float, ki: float, kd: float) -> cfg.Params:
    gains = {"kp": [float(kp)], "ki": [float(ki)], "kd": [float(kd)]}
    return cfg.merge(params, {"pid_controller": {**gains, "min_delay_margin_periods": 0}})  # Ku's search is unstable
