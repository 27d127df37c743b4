"""``identify`` on a chain of joints: each joint's armature, damping and Coulomb friction and a payload on the last
link, fitted together (``core/model/chain_identification``) to a run's recording, written as the controller's
``model_inertia``, ``model_damping``, ``model_coulomb_friction`` and ``model_payload`` (``identified.yaml``), flat
figures (``identification.json``) and a report beside the URDF's values (``identification.md``)."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.model.chain_identification import JOINT_PARAMETERS, ChainFit, ChainJointFit
from robot_controller.core.model.chain_parsimony import FRICTION_FLOOR_SHARE
from robot_controller.scoring import report

# Per joint, the values reported: (field, key's stem, key's unit, readable name, readable unit).
ROWS = (
    ("inertia", "inertia", "kg_m2", "inertia at q = 0", "kg·m²"),
    ("armature", "armature", "kg_m2", "armature added", "kg·m²"),
    ("damping", "damping", "nm_s_per_rad", "damping", "N·m·s/rad"),
    ("coulomb_friction", "coulomb_friction", "nm", "Coulomb friction", "N·m"),
)
PAYLOAD_NAMES = ("mass_kg", "x_m", "y_m", "z_m")
# Why a value fitted below 0 is set to 0 (beyond its noise, a sign the URDF is off where the fit cannot follow).
WHY = {
    "armature": " (the chain's model adds inertia to its links, never takes theirs away; beyond the noise, its links "
    "turn more easily than the URDF says)",
    "damping": "",
    "coulomb_friction": "",
}


def rounded_up(value: float) -> float:
    """``value`` to 6 significant digits, never below it: the controller's chain model refuses an inertia below its
    links' own, and a value rounded down by a digit would be."""
    if value <= 0 or not math.isfinite(value):
        return float(value)
    unit = 10.0 ** (math.floor(math.log10(value)) - 5)
    return float(f"{math.ceil(value / unit - 1e-9)}e{math.floor(math.log10(unit))}")


def payload_values(fit: ChainFit) -> list[float]:
    """The overlay's ``model_payload``: the fitted one, or no load ([0, 0, 0, 0]) when none was found."""
    return [float(f"{v:.6g}") for v in fit.payload.payload.as_values()] if fit.payload_found else [0.0] * 4


def overlay(params: cfg.Params, fit: ChainFit) -> cfg.Params:
    """The controller's ``model_*`` values, one per joint, and ``model_payload``. Each inertia is M(0)'s diagonal
    as the controller computes it with this payload, plus the armature fitted."""
    from robot_controller.core.model import ArmDynamics, Payload

    payload = payload_values(fit)
    urdf = resources.resolve_urdf(params["pid_controller"]["urdf_path"])
    model = ArmDynamics(urdf, Payload.from_values("model_payload", payload))
    diagonal = np.diag(model.mass_matrix(np.zeros(len(fit.joints))))
    return {
        "pid_controller": {
            "model_inertia": [rounded_up(d + joint.armature) for d, joint in zip(diagonal, fit.joints, strict=True)],
            "model_damping": [float(f"{joint.damping:.6g}") for joint in fit.joints],
            "model_coulomb_friction": [float(f"{joint.coulomb_friction:.6g}") for joint in fit.joints],
            "model_payload": payload,
        }
    }


def flat_results(fit: ChainFit) -> dict[str, Any]:
    """Per joint and for the payload: value, standard error, residual, samples (flat keys, units in the names)."""
    out: dict[str, Any] = {"fitted": "joints and payload"}
    for joint in fit.joints:
        for field, stem, unit, _, _ in ROWS:
            out[f"{joint.name}_{stem}_{unit}"] = getattr(joint, field)
            out[f"{joint.name}_{stem}_stderr_{unit}"] = getattr(joint, f"{field}_stderr")
        out[f"{joint.name}_urdf_inertia_kg_m2"] = joint.urdf_inertia
        out[f"{joint.name}_urdf_damping_nm_s_per_rad"] = joint.urdf_damping
        out[f"{joint.name}_urdf_coulomb_friction_nm"] = joint.urdf_coulomb_friction
        out[f"{joint.name}_identified"] = joint.identified
        out[f"{joint.name}_not_identified_why"] = joint.reason or None
        out[f"{joint.name}_clipped_to_zero"] = list(joint.clipped)
        out[f"{joint.name}_kept_urdf"] = list(joint.kept)  # not told from the URDF's: its value in the overlay
        for name, value in zip(JOINT_PARAMETERS, joint.fitted, strict=True):
            out[f"{joint.name}_{name}_fitted_{dict((r[0], r[2]) for r in ROWS)[name]}"] = value
        out[f"{joint.name}_residual_rms_nm"] = joint.residual_rms_nm
        out[f"{joint.name}_samples"] = joint.samples
        for why in ("braked", "saturated", "slow", "other"):
            out[f"{joint.name}_excluded_{why}"] = getattr(joint, f"excluded_{why}")
    payload, found = fit.payload, fit.payload_found
    mass, centre = payload.payload.mass_kg, payload.payload.com_m
    out.update(payload_found=found, payload_mass_kg=mass)
    out.update(zip(("payload_x_m", "payload_y_m", "payload_z_m"), centre if found else (None,) * 3, strict=True))
    out.update({f"payload_{name}_stderr": err for name, err in zip(PAYLOAD_NAMES, payload.stderr, strict=True)})
    out.update(payload_unidentifiable=list(payload.unidentifiable) if found else [])
    out.update(
        residual_rms_nm=fit.residual_rms_nm,
        residual_rms_without_payload_nm=fit.residual_rms_without_payload_nm,
        residual_rms_urdf_alone_nm=fit.residual_rms_urdf_nm,
        samples=payload.samples,
    )
    return {key: (None if isinstance(v, float) and not math.isfinite(v) else v) for key, v in out.items()}


def _value(joint: ChainJointFit, field: str) -> tuple[str, str]:
    value, err = getattr(joint, field), getattr(joint, f"{field}_stderr")
    if not joint.identified:
        return f"{value:.4g} (the URDF's)", "—"
    clipped = f" ({joint.below_zero(field)}: set to 0)" if field in joint.clipped else ""
    if field in joint.kept:
        clipped = f" (fitted {joint.fitted[JOINT_PARAMETERS.index(field)]:.2g}: not told from the URDF's)"
    return f"{value:.4g}{clipped}", f"{err:.2g}"


def _urdf(joint: ChainJointFit, field: str) -> float:
    return {"inertia": joint.urdf_inertia, "armature": 0.0, "damping": joint.urdf_damping}.get(
        field, joint.urdf_coulomb_friction
    )


def _kept(joint: ChainJointFit) -> str:
    """The values kept at the URDF's, and what fitting each would have saved."""
    each = ", ".join(
        f"{name.replace('_', ' ')} (fitted {joint.fitted[i]:.2g}, the URDF's {_urdf(joint, name):.2g}: "
        f"{100 * joint.kept_cost[i]:.0f} % more residual than all three fitted)"
        for i, name in enumerate(JOINT_PARAMETERS)
        if name in joint.kept
    )
    return (
        f"not told from the URDF's: {each}; the URDF's values kept (or none, a friction under "
        f"{100 * FRICTION_FLOOR_SHARE:g} % of the effort limit)"
    )


def limits(fit: ChainFit) -> list[str]:
    """What the fit could not tell, one sentence each."""
    said = [
        "Only a load on the last joint's link is fitted: the other links' masses and centres are the URDF's (a "
        "point mass on the last link is what the controller's `model_payload` can carry)."
    ]
    said += [f"`{j.name}` not identified: {j.reason}; the URDF's values kept." for j in fit.joints if not j.identified]
    for joint in fit.joints:
        if joint.kept:
            said.append(f"`{joint.name}`: {_kept(joint)}.")
        for name in joint.clipped:
            said.append(f"`{joint.name}`'s {name.replace('_', ' ')} {joint.below_zero(name)}: set to 0{WHY[name]}.")
    if fit.payload_found and fit.payload.unidentifiable:
        said.append(
            f"The payload's {', '.join(fit.payload.unidentifiable)} moves no joint's torque in this motion: set to 0."
        )
    return said


def markdown(fit: ChainFit, facts: dict[str, Any]) -> str:
    payload = fit.payload
    mass, (x, y, z) = payload.payload.mass_kg, payload.payload.com_m
    if fit.payload_found:
        carried = f"a payload of {mass:.4g} ± {payload.stderr[0]:.2g} kg at ({x:.4g}, {y:.4g}, {z:.4g}) m"
    else:
        carried = (
            f"no payload ({mass:.2g} ± {payload.stderr[0]:.2g} kg: not above three standard errors, or under 10 g; "
            "the joints' values are those fitted with none, and the overlay sets `model_payload` to [0, 0, 0, 0])"
        )
    tracking = (
        f" Tracking during the run (the controller as configured): {facts['tracking_rms_rad'] * 1e3:.2f} mrad RMS "
        "on the worst joint."
        if facts.get("tracking_rms_rad") is not None
        else ""
    )
    lines = [
        "# Identification: each joint and a payload on the last link",
        "",
        f"{facts['duration_s']:g} sim s, sim time, seed {facts['seed']}: a chirp through every joint "
        f"({', '.join(f'{a:g}' for a in facts['amplitude_rad'])} rad, {facts['start_hz']:g} → {facts['end_hz']:g} "
        "Hz); fitted on the true joint state and the applied torque. Per joint, tau = ID(q, v, a) + Δarmature·a + "
        "b·v + f_c·sign(v), ID being MuJoCo's inverse dynamics of the URDF's links with the payload, each joint's "
        "three numbers solved for each payload the search tries." + tracking,
        "",
        f"Found: {carried}.",
        "",
        "| joint | parameter | identified | ± standard error | controller's URDF | identified / URDF |",
        "|---|---|---|---|---|---|",
    ]
    for joint in fit.joints:
        for field, _, _, readable, unit in ROWS:
            value, err = _value(joint, field)
            ref = _urdf(joint, field)
            ratio = f"{getattr(joint, field) / ref:.2f}" if ref != 0 else "n/a"
            lines.append(f"| {joint.name} | {readable} [{unit}] | {value} | {err} | {ref:.4g} | {ratio} |")
    lines += [
        "",
        "| joint | residual RMS [N·m] | samples used | left out: braked or torque off | saturated | slow or "
        "reversing | other |",
        "|---|---|---|---|---|---|---|",
        *(
            f"| {j.name} | {j.residual_rms_nm:.3g} | {j.samples} | {j.excluded_braked} | {j.excluded_saturated} "
            f"| {j.excluded_slow} | {j.excluded_other} |"
            for j in fit.joints
        ),
        "",
        "| payload | identified | ± standard error |",
        "|---|---|---|",
        *(
            _payload_row(name, value, err, shown=fit.payload_found or name == "mass_kg")
            for name, value, err in zip(PAYLOAD_NAMES, payload.payload.as_values(), payload.stderr, strict=True)
        ),
        "",
        f"Torque left unexplained: {fit.residual_rms_nm:.3g} N·m RMS as identified, "
        f"{fit.residual_rms_without_payload_nm:.3g} N·m fitted with no payload, {fit.residual_rms_urdf_nm:.3g} "
        "N·m with the URDF alone (its damping and friction, no payload).",
        "",
        "Inertia at q = 0 is M(0)'s diagonal with the payload plus the armature: what the controller's "
        "`model_inertia` means on a chain (the rest of M(q) is the URDF's). Standard errors are the least squares' "
        "(σ²·(XᵀX)⁻¹ per joint at the fitted payload); the residuals correlate in time, so they are optimistic. "
        "A simulated arm's implicit damping adds about b × half its physics step to the armature.",
        "",
        "What it cannot identify:",
        "",
        *(f"- {line}" for line in limits(fit)),
        "",
        "Use: `--config <your arm's files> --config identified.yaml` (it sets only the controller's `model_*` values; "
        "`run` passes `model_payload` on to the planner).",
        "",
    ]
    return "\n".join(lines)


def _payload_row(name: str, value: float, stderr: float, *, shown: bool) -> str:
    """One payload parameter's row; ``shown`` False: no payload was found, so it has no value."""
    if not shown:
        return f"| {name} | — (no payload) | — |"
    if not np.isfinite(stderr):
        return f"| {name} | {value:.4g} (not identifiable: no joint's torque depends on it) | — |"
    return f"| {name} | {value:.4g} | {stderr:.2g} |"


def progress_lines(fit: ChainFit) -> list[str]:
    """One line per joint, as the one-joint path says it, then the payload's."""
    lines = []
    for joint in fit.joints:
        if not joint.identified:
            lines.append(f"identify: {joint.name}: not identified ({joint.reason}); the URDF's values kept")
            continue
        values = ", ".join(
            f"{readable} {getattr(joint, field):.4g} ± {getattr(joint, field + '_stderr'):.2g} {unit}"
            for field, _, _, readable, unit in ROWS
        )
        clipped = "".join(f" ({name.replace('_', ' ')} {joint.below_zero(name)}: set to 0)" for name in joint.clipped)
        clipped += f" ({_kept(joint)})" if joint.kept else ""
        lines.append(
            f"identify: {joint.name}: {values}{clipped}; residual {joint.residual_rms_nm:.3g} N·m RMS over "
            f"{joint.samples} samples"
        )
    payload = fit.payload
    mass, (x, y, z) = payload.payload.mass_kg, payload.payload.com_m
    unexplained = (
        f"torque unexplained {fit.residual_rms_nm:.3g} N·m RMS (the URDF alone: {fit.residual_rms_urdf_nm:.3g})"
    )
    if not fit.payload_found:
        none = f"identify: no payload found on the last link ({mass:.2g} ± {payload.stderr[0]:.2g} kg)"
        lines.append(f"{none}; {unexplained}")
    else:
        unseen = f"; {', '.join(payload.unidentifiable)} not identifiable (no joint's torque depends on it): set to 0"
        found = f"identify: payload {mass:.3f} kg at ({x:.3f}, {y:.3f}, {z:.3f}) m on the last link; {unexplained}"
        lines.append(found + (unseen if payload.unidentifiable else ""))
    return lines


def identify_chain(
    params: cfg.Params,
    out: Path,
    motion: tuple,
    left_out: dict[str, np.ndarray],
    facts: dict[str, Any],
    progress: Callable[[str], None],
) -> dict[str, Any]:
    """Fit the chain to a run's ``motion`` (true time, position, velocity, applied torque) less what is ``left_out``;
    write the overlay and the reports into ``out``."""
    from robot_controller.core.model.chain_identification import fit_chain

    fit = fit_chain(resources.resolve_urdf(params["pid_controller"]["urdf_path"]), *motion, **left_out)
    run_keys = ("tracking_rms_rad", "peak_torque_nm", "saturated_ticks")
    results = {
        **flat_results(fit),
        **{f"excitation_{k}": v for k, v in facts.items() if k not in run_keys},
        **{f"run_{k}": facts.get(k) for k in run_keys},
        "simulator_urdf": params["simulator"]["urdf_path"],
        "controller_urdf": params["pid_controller"]["urdf_path"],
    }
    cfg.write_params_file(overlay(params, fit), out / "identified.yaml")
    report.write_metrics(out / "identification.json", results)
    (out / "identification.md").write_text(markdown(fit, facts))
    for line in progress_lines(fit):
        progress(line)
    progress(f"identify: wrote {out / 'identified.yaml'}, identification.json, identification.md")
    return results
