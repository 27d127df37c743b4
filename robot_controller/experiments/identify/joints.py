"""Identification on one joint: its four numbers (inertia, damping, Coulomb friction, gravity torque),
written as the controller's ``model_*`` overlay with ``identification.json`` and ``identification.md``."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.model import PARAMETERS, JointArmModel, JointFit, identify
from robot_controller.experiments.identify.excitation import fit_inputs
from robot_controller.parameters.builders import MODEL_KEYS
from robot_controller.scoring import report

UNITS = {"inertia": "kg_m2", "damping": "nm_s_per_rad", "coulomb_friction": "nm", "gravity_torque": "nm"}
READABLE_UNITS = {"inertia": "kg·m²", "damping": "N·m·s/rad", "coulomb_friction": "N·m", "gravity_torque": "N·m"}


def urdf_model(params: cfg.Params) -> JointArmModel:
    """The controller's URDF as the same four numbers per joint (what identification corrects)."""
    from robot_controller.core.model import ArmDynamics

    return JointArmModel.over_urdf(ArmDynamics(resources.resolve_urdf(params["pid_controller"]["urdf_path"])))


def overlay(fits: list[JointFit]) -> cfg.Params:
    """The parameter overlay: the controller's ``model_*`` values, one per joint."""
    return {
        "pid_controller": {
            key: [float(f"{getattr(fit, name):.6g}") for fit in fits]
            for key, name in zip(MODEL_KEYS, PARAMETERS, strict=True)
        }
    }


def flat_results(joint_names: list[str], fits: list[JointFit]) -> dict[str, Any]:
    """Per joint: value, standard error, residual RMS, samples (flat keys, units in the names)."""
    out: dict[str, Any] = {}
    for name, fit in zip(joint_names, fits, strict=True):
        for parameter in PARAMETERS:
            out[f"{name}_{parameter}_{UNITS[parameter]}"] = float(getattr(fit, parameter))
            out[f"{name}_{parameter}_stderr_{UNITS[parameter]}"] = float(getattr(fit, f"{parameter}_stderr"))
        out[f"{name}_residual_rms_nm"] = fit.residual_rms_nm
        out[f"{name}_samples"] = fit.samples
        for why in ("braked", "saturated", "slow", "other"):
            out[f"{name}_excluded_{why}"] = getattr(fit, f"excluded_{why}")
    return out


def markdown(joint_names: list[str], fits: list[JointFit], urdf: JointArmModel, facts: dict[str, Any]) -> str:
    lines = [
        "# Identification",
        "",
        f"{facts['duration_s']:g} sim s, sim time, seed {facts['seed']}: chirp {facts['amplitude_rad']:g} rad "
        f"from {facts['start_hz']:g} to {facts['end_hz']:g} Hz; fitted on the true joint state and the "
        "applied torque, tau = I·a + b·v + f_c·sign(v) + G·cos(q). Tracking during the run "
        f"(the controller as configured): {facts['tracking_rms_rad'] * 1e3:.2f} mrad RMS, "
        f"peak torque {facts['peak_torque_nm']:.2f} N·m.",
        "",
        "| joint | parameter | identified | ± standard error | controller's URDF | identified / URDF |",
        "|---|---|---|---|---|---|",
    ]
    urdf_values = {parameter: getattr(urdf, parameter) for parameter in PARAMETERS}
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
        *(
            f"| {name} | {fit.residual_rms_nm:.3g} | {fit.samples} | {fit.excluded_braked} "
            f"| {fit.excluded_saturated} | {fit.excluded_slow} | {fit.excluded_other} |"
            for name, fit in zip(joint_names, fits, strict=True)
        ),
        "",
        "Standard errors are the least-squares fit's (σ²·(XᵀX)⁻¹); the residuals of the "
        "filtered regression are correlated, so they are optimistic.",
        "",
        "Use: `--config <your arm's file> --config identified.yaml` (the overlay holds only the "
        "controller's `model_*` values).",
        "",
    ]
    return "\n".join(lines)


def identify_joints(
    params: cfg.Params,
    out: Path,
    recording: Any,
    joint_names: list[str],
    facts: dict[str, Any],
    progress: Callable[[str], None],
) -> dict[str, Any]:
    """Fit each joint's four numbers to the recording; write the overlay and the reports."""
    motion, left_out = fit_inputs(params, recording, len(joint_names))
    fits = identify(*motion, **left_out)
    run_keys = ("tracking_rms_rad", "peak_torque_nm", "saturated_ticks")
    results = {
        **flat_results(joint_names, fits),
        **{f"excitation_{k}": v for k, v in facts.items() if k not in run_keys},
        **{f"run_{k}": facts[k] for k in run_keys},
        "simulator_urdf": params["simulator"]["urdf_path"] or "(reference arm)",
        "controller_urdf": params["pid_controller"]["urdf_path"] or "(reference arm)",
    }
    cfg.write_params_file(overlay(fits), out / "identified.yaml")
    report.write_metrics(out / "identification.json", results)
    (out / "identification.md").write_text(markdown(joint_names, fits, urdf_model(params), facts))
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
