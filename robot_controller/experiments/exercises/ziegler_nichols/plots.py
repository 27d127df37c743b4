"""Exercise 1's plots: ``tune.png`` (every stage's step responses side by side)
and ``tune_sine.png`` (the gains chosen on the sine, the tutorial's beside them)."""

from __future__ import annotations

from pathlib import Path

from robot_controller.experiments.exercises.ziegler_nichols.settings import STAGE_STEP_RAD
from robot_controller.experiments.reporting import pyplot, save
from robot_controller.experiments.runs import Response, plot_steps


def plot_stages(
    path: Path, search, zn_response, kd_runs, ki_runs, chosen, tutorial_step, ku: float, kp: float, kd: float
) -> None:
    plt = pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(13, 8.5), constrained_layout=True)
    ordered = sorted(search, key=lambda r: r.figures["kp"])
    for response in ordered:
        tag = "oscillates on" if response.figures["sustained"] else "decays"
        response.label = f"Kp {response.figures['kp']:.3g} ({tag})"
    plot_steps(axes[0, 0], ordered, title=f"1. Kp alone (Ki = Kd = 0): Ku ≈ {ku:.3g} N·m/rad")
    plot_steps(
        axes[0, 1],
        ([zn_response] if zn_response else []) + kd_runs,
        title="2–3. Ziegler–Nichols, then Kd (Ki = 0) until the overshoot is gone",
    )
    plot_steps(
        axes[1, 0],
        ki_runs,
        title=f"4. then Ki (Kd {kd:.3g}) until the steady-state error is gone",
        band=(STAGE_STEP_RAD * 0.98, STAGE_STEP_RAD * 1.02),
    )
    final = [chosen] + ([tutorial_step] if tutorial_step else [])
    chosen.label = f"chosen: Kp {kp:.3g}, Ki {chosen.figures['ki']:.3g}, Kd {kd:.3g}"
    plot_steps(
        axes[1, 1],
        final + ([zn_response] if zn_response else []),
        title="the gains chosen",
        band=(STAGE_STEP_RAD * 0.98, STAGE_STEP_RAD * 1.02),
    )
    save(fig, path, "Exercise 1: tune the PID (the tutorial's controller, real graph, sim time)")


def plot_sine(path: Path, sine: Response, tutorial: Response | None) -> None:
    plt = pyplot()
    fig, (ax_q, ax_e) = plt.subplots(2, 1, figsize=(10, 6), sharex=True, constrained_layout=True)
    ax_q.plot(sine.time_s, sine.reference, "k--", lw=0.9, label="reference")
    for response in [sine] + ([tutorial] if tutorial else []):
        ax_q.plot(response.time_s, response.position, lw=1.1, label=response.label)
        ax_e.plot(response.time_s, response.reference - response.position, lw=1.0, label=response.label)
    ax_q.set_ylabel("joint angle, true [rad]")
    ax_e.set_ylabel("reference − true [rad]")
    ax_e.set_xlabel("time [s]")
    for ax in (ax_q, ax_e):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    save(fig, path, "The gains chosen on the sine (1 rad, 0.5 Hz)")
