"""The Panda through libfranka on the stand-in Franka robot (franka-sim, our Panda inside, its communication
constraints and motion limits enforced), at 1 kHz on the robot's clock, in process: how long a tick takes against the
1 ms budget, how many cycles the robot counts missed, its success rate, and the tracking. franka-sim's venv is made
by ``make franka-sim``; without it, or without pylibfranka, the figures are not measured and say why."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg

WARMUP_S = 2.0  # the start (a hold, then the blend from where the arm stood) is not scored
FIGURES = (
    "franka_tracking_rms_rad",
    "franka_tick_p50_ms",
    "franka_tick_p99_ms",
    "franka_tick_max_ms",
    "franka_missed",
    "franka_success_rate_min",
    "franka_guard_ticks",
)


def franka_run(params: cfg.Params, out: Path, duration_s: float) -> dict[str, Any]:
    """``duration_s`` s of the Panda's loop on a fresh stand-in; :data:`FIGURES`, or ``franka_failure`` saying what
    kept them from being measured (or what the robot did)."""
    try:
        import pylibfranka  # noqa: F401 - only whether it is there
    except ImportError:
        return {"franka_failure": "pylibfranka is not installed (the franka extra)"}
    from robot_controller.hardware import franka_server
    from robot_controller.hardware.franka_arm import ROTOR_INERTIA_KGM2, FrankaArm, RobotFault
    from robot_controller.hardware.robot_loop import robot_loop

    if not (franka_server.default_venv() / ".installed").is_file():
        return {"franka_failure": "franka-sim's venv is missing: run `make franka-sim`"}
    out.mkdir(parents=True, exist_ok=True)
    mjcf = franka_server.write_panda_mjcf(out)
    loop = robot_loop(params, ROTOR_INERTIA_KGM2)
    flags = ("--enforce-comm-constraints", "--enforce-motion-limits")
    try:
        with franka_server.FrankaServer(mjcf, flags=flags) as server:
            arm = FrankaArm(server.host)
            try:
                run = loop.run(arm, duration_s)
            finally:
                arm.close()
    except (franka_server.FrankaServerError, RobotFault) as exc:
        return {"franka_failure": str(exc)}
    result = run.loop
    scored = result.tick_time_s > WARMUP_S
    error = (result.true_position - result.reference)[scored]
    timing = run.timing()
    figures = {
        "franka_tracking_rms_rad": float(np.sqrt((error**2).mean(axis=0)).max()) if error.size else None,
        "franka_tick_p50_ms": timing["tick_compute_p50_ms"],
        "franka_tick_p99_ms": timing["tick_compute_p99_ms"],
        "franka_tick_max_ms": timing["tick_compute_max_ms"],
        "franka_missed": run.missed,
        "franka_success_rate_min": timing["success_rate_min"],
        "franka_guard_ticks": int(sum(run.guard_acted)),
    }
    if run.fault is not None:
        stopped_s = result.tick_time_s[-1]
        figures["franka_failure"] = f"the robot stopped the motion at {stopped_s:.2f} s: {run.fault.describe()}"
    return figures
