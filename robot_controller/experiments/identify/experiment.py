"""Identification of the real arm (``robot-controller identify``): one sim-time run of the stack with
the planner in ``chirp`` mode, the model fitted to the TRUE joint state and the applied torque (each
joint's four numbers, ``joints``; on a chain, a payload on the last link, ``payload``), written into
``out`` as ``identified.yaml`` (an overlay), ``identification.json``, ``identification.md`` and ``run/``."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from robot_controller import parameters as cfg
from robot_controller.experiments.identify.excitation import (
    AMPLITUDE_RAD,
    END_HZ,
    START_HZ,
    excitation_params,
    joint_names,
)
from robot_controller.experiments.identify.joints import identify_joints
from robot_controller.experiments.identify.payload import identify_payload
from robot_controller.experiments.step import run_and_score


def identify(
    params: cfg.Params,
    out: Path,
    *,
    duration_s: float = 20.0,
    seed: int = 0,
    progress: Callable[[str], None] = print,
    amplitude_rad: float = AMPLITUDE_RAD,
    start_hz: float = START_HZ,
    end_hz: float = END_HZ,
    domain_id: int | None = None,
) -> dict[str, Any]:
    """Excite the arm through the whole stack, fit its model, write the results into ``out``.

    :returns: what ``identification.json`` holds
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    run_params = excitation_params(params, duration_s, amplitude_rad=amplitude_rad, start_hz=start_hz, end_hz=end_hz)
    run_params["sensor_node"]["seed"] = seed
    chirp = f"{duration_s:g} sim s of a chirp, {amplitude_rad:g} rad, {start_hz:g} → {end_hz:g} Hz"
    run_dir = out / "run"
    progress(f"identify: {chirp} (sim time, run in {run_dir})")
    scored, recording = run_and_score(run_params, run_dir, duration_s=duration_s, sim_time=True, domain_id=domain_id)
    names = joint_names(run_params)
    progress(f"identify: fitting {len(recording.true_time_s)} samples of {', '.join(names)}")
    if len(names) > 1:
        return identify_payload(run_params, out, recording, scored, duration_s, seed, progress)
    facts = {"duration_s": float(duration_s), "seed": int(seed), "amplitude_rad": float(amplitude_rad)}
    facts.update(start_hz=float(start_hz), end_hz=float(end_hz))
    facts.update({key: scored.get(key) for key in ("tracking_rms_rad", "peak_torque_nm", "saturated_ticks")})
    return identify_joints(run_params, out, recording, names, facts, progress)
