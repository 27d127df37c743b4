"""Identification on a chain of joints: a payload on the last link (four numbers per joint would fold the
coupling into wrong values), written as the controller's ``model_payload`` overlay with its report."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.experiments.identify.excitation import fit_inputs


def identify_payload(
    params: cfg.Params,
    out: Path,
    recording: Any,
    scored: dict[str, Any],
    duration_s: float,
    seed: int,
    progress: Callable[[str], None],
) -> dict[str, Any]:
    """A chain of joints: fit a payload on the last link to the recording, write the overlay and reports."""
    from robot_controller.core.model import fit_payload
    from robot_controller.scoring import report

    motion, left_out = fit_inputs(params, recording, recording.joint_count)
    fit = fit_payload(resources.resolve_urdf(params["pid_controller"]["urdf_path"]), *motion, **left_out)
    mass, (x, y, z) = fit.payload.mass_kg, fit.payload.com_m
    # No mass above its noise: the arm carries nothing the URDF lacks, and the overlay says so.
    overlay = fit.payload.as_values() if fit.found else [0.0, 0.0, 0.0, 0.0]
    results: dict[str, Any] = {"fitted": "payload", "payload_found": fit.found, "payload_mass_kg": mass}
    centre = (x, y, z) if fit.found else (None, None, None)  # with no payload found its centre means nothing
    results.update(zip(("payload_x_m", "payload_y_m", "payload_z_m"), centre, strict=True))
    stderr_keys = ("mass_kg", "x_m", "y_m", "z_m")
    results.update({f"payload_{name}_stderr": float(err) for name, err in zip(stderr_keys, fit.stderr, strict=True)})
    results.update(payload_unidentifiable=list(fit.unidentifiable) if fit.found else [])
    results.update(residual_rms_nm=fit.residual_rms_nm, residual_rms_urdf_alone_nm=fit.residual_rms_without_nm)
    results.update(samples=fit.samples, excitation_duration_s=float(duration_s), excitation_seed=int(seed))
    results.update(run_tracking_rms_rad=scored.get("tracking_rms_rad"), run_peak_torque_nm=scored.get("peak_torque_nm"))
    results.update(
        simulator_urdf=params["simulator"]["urdf_path"], controller_urdf=params["pid_controller"]["urdf_path"]
    )
    payload = {"model_payload": [float(f"{v:.6g}") for v in overlay]}
    cfg.write_params_file({"pid_controller": payload}, out / "identified.yaml")
    report.write_metrics(out / "identification.json", results)
    labels = ("mass [kg]", "x [m]", "y [m]", "z [m]")
    rows = zip(labels, fit.payload.as_values(), fit.stderr, strict=True)
    none_found = [
        "No payload found: the mass is not above three standard errors, or under 10 g. The "
        "overlay sets `model_payload` to no load ([0, 0, 0, 0]).",
        "",
    ]
    lines = [
        "# Identification: a payload on the last link",
        "",
        f"{duration_s:g} sim s, sim time, seed {seed}: a chirp through every joint; fitted on the true "
        "joint state and the applied torque, by the URDF's inverse dynamics with a point mass welded to "
        "the last joint's link (MuJoCo's mj_inverse, every joint at once). Tracking during the run (the "
        f"controller as configured): {(scored.get('tracking_rms_rad') or float('nan')) * 1e3:.2f} mrad "
        "RMS on the worst joint.",
        "",
        "| parameter | identified | ± standard error |",
        "|---|---|---|",
        *(_row(name, value, err, shown=fit.found or name.startswith("mass")) for name, value, err in rows),
        "",
        *([] if fit.found else none_found),
        f"Torque left unexplained: {fit.residual_rms_nm:.3g} N·m RMS with the payload, "
        f"{fit.residual_rms_without_nm:.3g} N·m with the URDF alone, over {fit.samples} intervals "
        "(every joint).",
        "",
        "Use: `--config identified.yaml` after your other files (it sets only the controller's "
        "`model_payload`; `run` passes it on to the planner).",
        "",
    ]
    (out / "identification.md").write_text("\n".join(lines))
    unexplained = (
        f"torque unexplained {fit.residual_rms_nm:.3g} N·m RMS (the URDF alone: {fit.residual_rms_without_nm:.3g})"
    )
    if not fit.found:
        progress(f"identify: no payload found on the last link ({mass:.2g} ± {fit.stderr[0]:.2g} kg); {unexplained}")
    else:
        unseen = f"; {', '.join(fit.unidentifiable)} not identifiable (no joint's torque depends on it): set to 0"
        found = f"identify: payload {mass:.3f} kg at ({x:.3f}, {y:.3f}, {z:.3f}) m on the last link; {unexplained}"
        progress(found + (unseen if fit.unidentifiable else ""))
    progress(f"identify: wrote {out / 'identified.yaml'}, identification.json, identification.md")
    return results


def _row(name: str, value: float, stderr: float, *, shown: bool) -> str:
    """One parameter's row of the report; ``shown`` False: no payload was found, so it has no value."""
    if not shown:
        return f"| {name} | — (no payload) | — |"
    if not np.isfinite(stderr):
        return f"| {name} | {value:.4g} (not identifiable: no joint's torque depends on it) | — |"
    return f"| {name} | {value:.4g} | {stderr:.2g} |"
