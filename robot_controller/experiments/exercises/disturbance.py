"""Exercise 2, "Add a disturbance": a 2 N·m step torque at t = 5 s while the arm tracks the sine
(the simulator's scheduled disturbance). Per controller two seeded sim-time runs, pushed and not,
with the same sensor noise: their difference is the push's own effect."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.experiments import reporting
from robot_controller.experiments.compare import Contender, law_contender
from robot_controller.experiments.reporting import Progress, cells, pyplot, save, table, write_report, write_results
from robot_controller.experiments.step import SEED, run_and_score
from robot_controller.scoring import report

TORQUE_NM = 2.0
START_S = 5.0  #: physics time of the disturbance (the physics starts with the first command)
#: "Back" means within this of the reference again, and staying there.
RECOVERED_RAD = 0.002
#: The default controller's goal (exercise 2): pushed at most this far, back within this long.
GOAL_PEAK_RAD, GOAL_RECOVERY_S = 0.010, 0.3

PID_NO_FILTER = {"controller_type": "pid", "estimator": "none"}
CONTENDERS = (
    Contender("tutorial", "the tutorial's PID as written (Kp 50, Ki 10, Kd 5, no feedforward)", "tutorial", {}),
    Contender("pid", "PID (Kp 50, Ki 10, Kd 5) with the model's feedforward, no filter", "default", PID_NO_FILTER),
    Contender("default", "the default: LQR, Kalman filter, feedforward", "default", {}),
)


def _plan(quick: bool) -> dict[str, Any]:
    return {"after_s": 1.5 if quick else 3.0, "contenders": (CONTENDERS[0], CONTENDERS[2]) if quick else CONTENDERS}


RUNS_PER_CONTENDER = 2  #: pushed and undisturbed, a progress step each


def steps(quick: bool = False) -> int:
    return RUNS_PER_CONTENDER * len(_plan(quick)["contenders"])


def contender_params(contender: Contender, seed: int, duration_s: float, torque_nm: float = TORQUE_NM) -> cfg.Params:
    push = {"disturbance_torque_nm": [torque_nm], "disturbance_start_s": START_S, "disturbance_duration_s": duration_s}
    run = {"sensor_node": {"seed": seed}, "simulator": push}
    return cfg.merge(contender.params(), run)


def deviation_figures(
    time_s: np.ndarray, error: np.ndarray, start_s: float, band_from_before: bool = True
) -> dict[str, float]:
    """From the tracking error (reference − true, rad) on a timeline (s): ``peak_deviation_rad`` after
    ``start_s``, ``before_max_rad`` (the second before), and ``recovery_s``: until the error is back
    within ``RECOVERED_RAD`` (with ``band_from_before``: or 1.2× ``before_max_rad``, if wider) for good."""
    before = (time_s >= start_s - 1.0) & (time_s < start_s)
    after = time_s >= start_s
    before_max = float(np.max(np.abs(error[before]))) if np.any(before) else float("nan")
    band = max(RECOVERED_RAD, 1.2 * before_max) if band_from_before and np.isfinite(before_max) else RECOVERED_RAD
    t_after, e_after = time_s[after], np.abs(error[after])
    outside = np.flatnonzero(e_after > band)
    if len(outside) == 0:
        recovery = 0.0
    elif outside[-1] == len(e_after) - 1:
        recovery = float("nan")  # not back by the end of the run
    else:
        recovery = float(t_after[outside[-1] + 1] - start_s)
    return {
        "peak_deviation_rad": float(np.max(e_after)) if len(e_after) else float("nan"),
        "before_max_rad": before_max,
        "recovery_band_rad": band,
        "recovery_s": recovery,
    }


def _error_on_timeline(recording: Any, duration_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Every true-state sample on the simulator's timeline (s) and the reference in force minus it (rad)."""
    t = recording.true_time_s
    reference, valid = report.reference_in_force(recording)
    keep = (t <= duration_s) & valid
    return t[keep], reference[keep, 0] - recording.true_position[keep, 0]


def push_effect(
    pushed: tuple[np.ndarray, np.ndarray], undisturbed: tuple[np.ndarray, np.ndarray]
) -> tuple[np.ndarray, np.ndarray]:
    """The push's own effect on the tracking error: the pushed run's error minus the unpushed one's,
    on the samples both have (the same noise draws: they agree to the bit until the push)."""
    t_pushed, e_pushed = pushed
    t_plain, e_plain = undisturbed
    ticks_pushed, ticks_plain = np.round(t_pushed * 1e6).astype(np.int64), np.round(t_plain * 1e6).astype(np.int64)
    common, i_pushed, i_plain = np.intersect1d(ticks_pushed, ticks_plain, return_indices=True)
    return common * 1e-6, e_pushed[i_pushed] - e_plain[i_plain]


def run(
    out: Path, *, quick: bool = False, progress: Progress = print, seed: int = SEED, controller: str | None = None
) -> dict[str, Any]:
    """``controller`` (``--controller SPEC``): that law runs too, after the others, with the default stack."""
    plan = _plan(quick)
    if controller is not None:
        law = law_contender(controller)
        if law.name in {c.name for c in CONTENDERS}:
            law = replace(law, name=f"law_{law.name}")
        plan["contenders"] = (*plan["contenders"], law)
    out.mkdir(parents=True, exist_ok=True)
    duration_s = START_S + plan["after_s"]
    results: dict[str, Any] = {"quick": int(quick), "seed": seed, "torque_nm": TORQUE_NM, "start_s": START_S}
    traces = {}
    for contender in plan["contenders"]:
        name = contender.name
        errors = {}
        for torque_nm in (TORQUE_NM, 0.0):
            label = "pushed" if torque_nm else "undisturbed"
            progress(f"{name}, {label}: {torque_nm:g} N·m from t = {START_S:g} s")
            params = contender_params(contender, seed, duration_s, torque_nm)
            _, recording = run_and_score(params, out / name / label, duration_s=duration_s, sim_time=True)
            errors[label] = _error_on_timeline(recording, duration_s)
        effect = push_effect(errors["pushed"], errors["undisturbed"])
        own = deviation_figures(*effect, START_S, band_from_before=False)
        raw = deviation_figures(*errors["pushed"], START_S)
        results[f"{name}_peak_deviation_rad"] = own["peak_deviation_rad"]
        results[f"{name}_recovery_s"] = own["recovery_s"]
        results[f"{name}_peak_error_rad"] = raw["peak_deviation_rad"]
        results[f"{name}_error_recovery_s"] = raw["recovery_s"]
        results[f"{name}_before_max_rad"] = raw["before_max_rad"]
        results[f"{name}_error_recovery_band_rad"] = raw["recovery_band_rad"]
        traces[name] = (errors["pushed"], effect)
    results = write_results(out, results)
    _plot(out / "disturbance.png", traces)
    write_report(out, _report(results, plan, quick))
    return results


def _plot(path: Path, traces: dict[str, tuple[tuple[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]]) -> None:
    """Above, each pushed run's tracking error; below, the push's own effect around the push."""
    plt = pyplot()
    fig, (ax_all, ax_zoom) = plt.subplots(2, 1, figsize=(10, 7), constrained_layout=True)
    for name, ((t, error), (t_effect, effect)) in traces.items():
        ax_all.plot(t, error * 1e3, lw=0.9, label=name)
        near = (t_effect >= START_S - 0.2) & (t_effect <= START_S + 1.0)
        ax_zoom.plot(t_effect[near] - START_S, effect[near] * 1e3, lw=1.1, label=name)
    reporting.label_axes(ax_all, "physics time [s] (the pushed runs)", "reference − true [mrad]")
    zoom = "time since the disturbance [s] (pushed run's error − the undisturbed run's, same noise)"
    reporting.label_axes(ax_zoom, zoom, "the push's own effect [mrad]")
    ax_all.axvline(START_S, color="r", lw=0.7)
    ax_zoom.axvline(0.0, color="r", lw=0.7)
    ax_zoom.axhspan(-RECOVERED_RAD * 1e3, RECOVERED_RAD * 1e3, color="0.88", lw=0, zorder=0)
    save(fig, path, f"Exercise 2: a {TORQUE_NM:g} N·m step disturbance at t = {START_S:g} s (real graph, sim time)")


def _report(results: dict[str, Any], plan: dict[str, Any], quick: bool) -> str:
    never = f"not in {plan['after_s']:g} s"
    rows = [
        [
            f"**{c.name}**: {c.description}",
            *cells(results, (("peak_deviation_rad", "{:.1f}"),), f"{c.name}_", 1e3),
            *cells(results, (("recovery_s", "{:.2f}", never),), f"{c.name}_"),
            *cells(results, (("before_max_rad", "{:.1f}"), ("peak_error_rad", "{:.1f}")), f"{c.name}_", 1e3),
            *cells(results, (("error_recovery_s", "{:.2f}", never),), f"{c.name}_"),
        ]
        for c in plan["contenders"]
    ]
    default = any(c.name == "default" for c in plan["contenders"]) and (
        results["default_peak_deviation_rad"] is not None and results["default_recovery_s"] is not None
    )
    verdict = ""
    if default:
        met = (
            results["default_peak_deviation_rad"] <= GOAL_PEAK_RAD and results["default_recovery_s"] <= GOAL_RECOVERY_S
        )
        verdict = (
            f"Goal for the default controller: pushed at most {GOAL_PEAK_RAD * 1e3:g} mrad, back within "
            f"{GOAL_RECOVERY_S:g} s: **{'met' if met else 'not met'}**."
        )
    return "\n".join(
        [
            "# Exercise 2: a step disturbance",
            "",
            "*The tutorial: apply a step torque disturbance of 2 N·m at t = 5 s and watch the controller recover.*",
            "",
            f"The arm tracks the reference sine (1 rad, 0.5 Hz). At physics time {START_S:g} s an external torque of "
            f"{TORQUE_NM:g} N·m starts acting on the joint and stays ({plan['after_s']:g} s recorded after it). Each "
            "controller runs twice on the whole graph (five processes, sim time, sensor seed "
            f"{results['seed']}), pushed and not; the error is the reference in force minus the TRUE angle, on the "
            "simulator's timeline. Both runs draw the same sensor noise, so they agree to the bit until the push: "
            "their difference after it is the push's own effect." + (" **Quick form**." if quick else ""),
            "",
            table(
                "controller | the push's own effect: peak [mrad] | back within 2 mrad [s] | "
                "pushed run: error before, max [mrad] | peak error [mrad] | back [s]",
                rows,
            ),
            "",
            f"*Back within*: from the push until the push's own effect is within {RECOVERED_RAD * 1e3:g} mrad and "
            "stays there. The last three columns are the pushed run's own error, sensor noise included: its "
            "recovery is until the error is back within 2 mrad, or 1.2× the largest error of the second before "
            "the push if that is wider, and stays there; the noise alone moves the error's slow wander past "
            "2 mrad now and then, so that column measures the noise as much as the push.",
            "",
            "What it shows: a constant torque the controller does not know about is first fought by the proportional "
            "and derivative terms (the arm is pushed until they balance it), then removed by the integral term, "
            "which takes as long as its gain allows. The feedforward does not help here: it knows the arm, not the "
            "push. The default also estimates the external torque (its Kalman filter's disturbance observer): a "
            "reading that stands out from the filter's prediction is taken as a jump of that torque, followed "
            "within a period or two and subtracted from the command.",
            "",
            verdict,
            "",
            "![error](disturbance.png)",
        ]
    )
