"""Identification of the real arm (``robot-controller identify``): drive it
through the whole stack with an excitation it can follow, fit the model to
what the simulator recorded, and write the result as a parameter file the
controller reads over its URDF. On one joint the fit is each joint's four
numbers (:mod:`robot_controller.core.model.identification`); on a chain of joints,
where those would fold the coupling between joints into wrong numbers, it is
a payload on the last link (:mod:`robot_controller.core.model.payload_identification`,
fitted and written by ``identify_payload``).

One lockstep (``--sim-time``) run of the graph as configured (so the
controller in charge is the one with the possibly wrong model), the planner
in ``chirp`` mode: a sine sweeping from ``start_hz`` to ``end_hz`` over the
whole run at ``amplitude_rad`` around the planner's ``offset`` (slow at
first, where gravity and friction dominate, faster later, where inertia
does). Then :func:`robot_controller.core.model.identification.identify` on the
TRUE joint state and the applied torque (``/sim/joint_states``), leaving
out what the brakes held, what saturated, and reversals.

``DIR`` receives:

- ``identified.yaml``: the ``pid_controller`` ``model_*`` values alone, to
  layer last: ``--config arm.yaml --config DIR/identified.yaml``;
- ``identification.json``: per joint the four values, their standard errors,
  the residual RMS and the samples used (flat keys, units in the names);
- ``identification.md``: the same as a table, beside the URDF's values;
- ``run/``: the run itself (``params.yaml``, ``bag/``).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.model import identification
from robot_controller.core.model.arm_model import PARAMETERS, JointArmModel
from robot_controller.parameters.builders import MODEL_KEYS
from robot_controller.parameters.limits import torque_limit as node_torque_limit

# The excitation: a chirp within the reference sine's range and speed, which an
# arm about four times the reference arm's inertia still follows inside 10 N·m.
AMPLITUDE_RAD = 0.8
START_HZ = 0.1
END_HZ = 0.5

UNITS = {"inertia": "kg_m2", "damping": "nm_s_per_rad", "coulomb_friction": "nm", "gravity_torque": "nm"}
READABLE_UNITS = {"inertia": "kg·m²", "damping": "N·m·s/rad", "coulomb_friction": "N·m", "gravity_torque": "N·m"}


def excitation_params(
    params: cfg.Params,
    duration_s: float,
    *,
    amplitude_rad: float = AMPLITUDE_RAD,
    start_hz: float = START_HZ,
    end_hz: float = END_HZ,
) -> cfg.Params:
    """``params`` with the planner in chirp mode, one sweep over ``duration_s``;
    on a chain of joints at the planner's own amplitudes (each within its
    joint's range about the robot's home pose), on one joint ``amplitude_rad``."""
    planner = params["trajectory_planner"]
    amplitude = [float(amplitude_rad)] if planner["joint_count"] == 1 else list(planner["amplitude"])
    return cfg.merge(
        params,
        {
            "trajectory_planner": {
                "mode": "chirp",
                "amplitude": amplitude,
                "frequency_hz": float(start_hz),
                "end_frequency_hz": float(end_hz),
                "sweep_time_s": float(duration_s),
            }
        },
    )


def _step_at(times_s: np.ndarray, event_times_s: np.ndarray, values: np.ndarray, joint_count: int) -> np.ndarray:
    """The latest of ``values`` (one row per event, one column per joint) at each
    of ``times_s`` (a step function; zero before the first event), as booleans."""
    out = np.zeros((len(times_s), joint_count), dtype=bool)
    if len(event_times_s) == 0:
        return out
    order = np.argsort(event_times_s, kind="stable")
    index = np.searchsorted(event_times_s[order], times_s, side="right") - 1
    known = index >= 0
    out[known] = np.asarray(values)[order][index[known]] != 0
    return out


def held_or_pushed(recording: Any) -> np.ndarray:
    """Per true-state sample and joint: a brake engaged, or an external
    disturbance acting (neither is in the model): left out of the fit."""
    t, n = recording.true_time_s, recording.joint_count
    mask = _step_at(t, recording.brakes_time_s, recording.brakes, n)
    if len(getattr(recording, "disturbance_time_s", ())):
        mask |= _step_at(t, recording.disturbance_time_s, recording.disturbance, n)
    return mask


def torque_limit(params: cfg.Params, joint_count: int) -> np.ndarray:
    """The torque beyond which a recorded effort is saturated: the smallest of
    the controller's and the motor's ``torque_max`` and the simulated arm's effort limit."""
    from robot_controller.core.model.plant import effort_limits, load_model

    limit = effort_limits(load_model(resources.resolve_urdf(params["simulator"]["urdf_path"])))
    for node in ("motor_node", "pid_controller"):
        limit = np.minimum(limit, node_torque_limit(params[node], joint_count))
    return limit


def urdf_model(params: cfg.Params) -> JointArmModel:
    """The controller's URDF as the same four numbers per joint (what identification corrects)."""
    from robot_controller.core.model.plant import ArmDynamics

    return JointArmModel.over_urdf(ArmDynamics(resources.resolve_urdf(params["pid_controller"]["urdf_path"])))


def overlay(fits: list[identification.JointFit]) -> cfg.Params:
    """The parameter overlay: the controller's ``model_*`` values, one per joint."""
    return {
        "pid_controller": {
            key: [float(f"{getattr(fit, name):.6g}") for fit in fits]
            for key, name in zip(MODEL_KEYS, PARAMETERS, strict=True)
        }
    }


def flat_results(joint_names: list[str], fits: list[identification.JointFit]) -> dict[str, Any]:
    """Per joint: value, standard error, residual RMS, samples (flat keys, units in the names)."""
    out: dict[str, Any] = {}
    for name, fit in zip(joint_names, fits, strict=True):
        for parameter in PARAMETERS:
            out[f"{name}_{parameter}_{UNITS[parameter]}"] = float(getattr(fit, parameter))
            out[f"{name}_{parameter}_stderr_{UNITS[parameter]}"] = float(getattr(fit, f"{parameter}_stderr"))
        out[f"{name}_residual_rms_nm"] = fit.residual_rms_nm
        out[f"{name}_samples"] = fit.samples
        out[f"{name}_excluded_braked"] = fit.excluded_braked
        out[f"{name}_excluded_saturated"] = fit.excluded_saturated
        out[f"{name}_excluded_slow"] = fit.excluded_slow
        out[f"{name}_excluded_other"] = fit.excluded_other
    return out


def markdown(
    joint_names: list[str], fits: list[identification.JointFit], urdf: JointArmModel, facts: dict[str, Any]
) -> str:
    lines = [
        "# Identification",
        "",
        f"{facts['duration_s']:g} sim s, lockstep, seed {facts['seed']}: chirp {facts['amplitude_rad']:g} rad "
        f"from {facts['start_hz']:g} to {facts['end_hz']:g} Hz; fitted on the true joint state and the "
        "applied torque, tau = I·a + b·v + f_c·sign(v) + G·cos(q). Tracking during the run "
        f"(the controller as configured): {facts['tracking_rms_rad'] * 1e3:.2f} mrad RMS, "
        f"peak torque {facts['peak_torque_nm']:.2f} N·m.",
        "",
        "| joint | parameter | identified | ± standard error | controller's URDF | identified / URDF |",
        "|---|---|---|---|---|---|",
    ]
    urdf_values = {
        "inertia": urdf.inertia,
        "damping": urdf.damping,
        "coulomb_friction": urdf.coulomb_friction,
        "gravity_torque": urdf.gravity_torque,
    }
    for j, (name, fit) in enumerate(zip(joint_names, fits, strict=True)):
        for parameter in PARAMETERS:
            value, err, ref = getattr(fit, parameter), getattr(fit, f"{parameter}_stderr"), urdf_values[parameter][j]
            ratio = f"{value / ref:.2f}" if ref != 0 else "n/a"
            lines.append(
                f"| {name} | {parameter.replace('_', ' ')} [{READABLE_UNITS[parameter]}] | {value:.4g} "
                f"| {err:.2g} | {ref:.4g} | {ratio} |"
            )
    lines += [
        "",
        "| joint | residual RMS [N·m] | samples used | left out: braked or torque off | saturated "
        "| slow or reversing | other |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, fit in zip(joint_names, fits, strict=True):
        lines.append(
            f"| {name} | {fit.residual_rms_nm:.3g} | {fit.samples} | {fit.excluded_braked} "
            f"| {fit.excluded_saturated} | {fit.excluded_slow} | {fit.excluded_other} |"
        )
    lines += [
        "",
        "Standard errors are the least-squares fit's (σ²·(XᵀX)⁻¹); the residuals of the "
        "filtered regression are correlated, so they are optimistic.",
        "",
        "Use: `--config <your arm's file> --config identified.yaml` (the overlay holds only the "
        "controller's `model_*` values).",
        "",
    ]
    return "\n".join(lines)


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
    """Excite the arm through the whole stack, fit its model, write the results
    into ``out`` (see the module's description); returns what
    ``identification.json`` holds."""
    from robot_controller.experiments.step import run_and_score

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    run_params = excitation_params(params, duration_s, amplitude_rad=amplitude_rad, start_hz=start_hz, end_hz=end_hz)
    run_params["sensor_node"]["seed"] = seed
    progress(
        f"identify: {duration_s:g} sim s of a chirp, {amplitude_rad:g} rad, {start_hz:g} → {end_hz:g} Hz "
        f"(lockstep, run in {out / 'run'})"
    )
    scored, recording = run_and_score(
        run_params, out / "run", duration_s=duration_s, sim_time=True, domain_id=domain_id
    )
    joint_names = _joint_names(run_params)
    progress(f"identify: fitting {len(recording.true_time_s)} samples of {', '.join(joint_names)}")
    if len(joint_names) > 1:
        from robot_controller.experiments.identify_payload import identify_payload

        return identify_payload(run_params, out, recording, scored, duration_s, seed, progress)
    fits = identification.identify(
        recording.true_time_s,
        recording.true_position,
        recording.true_velocity,
        recording.true_effort,
        effort_limit=torque_limit(run_params, len(joint_names)),
        braked=held_or_pushed(recording),
    )
    facts = {
        "duration_s": float(duration_s),
        "seed": int(seed),
        "amplitude_rad": float(amplitude_rad),
        "start_hz": float(start_hz),
        "end_hz": float(end_hz),
        "tracking_rms_rad": scored.get("tracking_rms_rad"),
        "peak_torque_nm": scored.get("peak_torque_nm"),
        "saturated_ticks": scored.get("saturated_ticks"),
    }
    results = {
        **flat_results(joint_names, fits),
        **{
            f"excitation_{k}": v
            for k, v in facts.items()
            if k not in ("tracking_rms_rad", "peak_torque_nm", "saturated_ticks")
        },
        "run_tracking_rms_rad": facts["tracking_rms_rad"],
        "run_peak_torque_nm": facts["peak_torque_nm"],
        "run_saturated_ticks": facts["saturated_ticks"],
        "simulator_urdf": run_params["simulator"]["urdf_path"] or "(reference arm)",
        "controller_urdf": run_params["pid_controller"]["urdf_path"] or "(reference arm)",
    }
    cfg.write_params_file(overlay(fits), out / "identified.yaml")
    from robot_controller.scoring import report

    report.write_metrics(out / "identification.json", results)
    (out / "identification.md").write_text(markdown(joint_names, fits, urdf_model(run_params), facts))
    for name, fit in zip(joint_names, fits, strict=True):
        progress(
            f"identify: {name}: "
            + ", ".join(
                f"{p} {getattr(fit, p):.4g} ± {getattr(fit, p + '_stderr'):.2g} {READABLE_UNITS[p]}" for p in PARAMETERS
            )
            + f"; residual {fit.residual_rms_nm:.3g} N·m RMS over {fit.samples} samples"
        )
    progress(f"identify: wrote {out / 'identified.yaml'}, identification.json, identification.md")
    return results


def _joint_names(params: cfg.Params) -> list[str]:
    from robot_controller.core.model.plant import joint_names, load_model

    return joint_names(load_model(resources.resolve_urdf(params["simulator"]["urdf_path"])))
