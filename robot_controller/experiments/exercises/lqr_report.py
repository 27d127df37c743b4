"""Exercise 4's report: the figure of the step and sine responses with each contender's
closed-loop poles, and ``report.md``'s tables of gains, poles, margins and figures, with the verdict."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from robot_controller.core.laws import robustness
from robot_controller.experiments.reporting import cells, fmt, pyplot, save, table
from robot_controller.experiments.runs import Response, plot_steps


def plot(
    path: Path,
    steps_run: list[Response],
    sines: list[Response],
    analyses: dict[str, dict[str, Any]],
    step_rad: float,
) -> None:
    plt = pyplot()
    fig = plt.figure(figsize=(14, 8.5), constrained_layout=True)
    grid = fig.add_gridspec(2, 2, width_ratios=(1.6, 1))
    ax_step, ax_sine, ax_poles = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[1, 0]), fig.add_subplot(grid[:, 1])
    plot_steps(ax_step, steps_run, band=(step_rad * 0.98, step_rad * 1.02), title=f"{step_rad:g} rad step (a jump)")
    for sine in sines:
        ax_sine.plot(sine.time_s, sine.reference - sine.position, lw=1.0, label=sine.label)
    ax_sine.set_xlabel("time [s]")
    ax_sine.set_ylabel("sine: reference − true [rad]")
    ax_sine.grid(alpha=0.3)
    ax_sine.legend(fontsize=8)
    theta = np.linspace(0, 2 * np.pi, 400)
    ax_poles.plot(np.cos(theta), np.sin(theta), "k-", lw=0.7)
    for (name, analysis), marker in zip(analyses.items(), "ox+", strict=False):
        poles = analysis["poles"]
        ax_poles.plot(poles.real, poles.imag, marker, ms=9, mfc="none", mew=1.5, label=name)
    ax_poles.set_xlim(0.4, 1.05)
    ax_poles.set_ylim(-0.3, 0.3)
    ax_poles.set_aspect("equal")
    ax_poles.grid(alpha=0.3)
    ax_poles.legend(fontsize=8)
    ax_poles.set_title("closed-loop poles, z-plane (zoomed; the unit circle in black)", fontsize=10)
    save(fig, path, "Exercise 4: PID against LQR (real graph, sim time)")


def report_text(results: dict[str, Any], plan: dict[str, Any], analyses: dict[str, dict[str, Any]], quick: bool) -> str:
    contenders = plan["contenders"]
    gain_rows = []
    for contender in contenders:
        a = analyses[contender.name]
        gain_rows.append(
            [
                f"**{contender.name}**: {contender.description}",
                *cells(a, (("kp", "{:.3g}"), ("ki", "{:.3g}"), ("kd", "{:.3g}"))),
                ", ".join(_pole_text(p) for p in a["poles"]),
                fmt(float(np.max(np.abs(a["poles"]))), "{:.4f}"),
                fmt(a["margins"].gain_margin_db, "{:.1f}"),
                fmt(a["margins"].phase_margin_deg, "{:.0f}"),
                str(a["delay_margin_periods"]),
            ]
        )
    never = f"not in {plan['after_s']:g} s"
    cols = (("sine_tracking_rms_rad", "{:.4f}"), ("sine_tracking_max_rad", "{:.4f}"), ("step_overshoot_pct", "{:.1f}"))
    cols += (("step_settling_time_s", "{:.2f}", never), ("step_rise_time_s", "{:.3f}"))
    cols += (("step_steady_state_error_rad", "{:.4f}"), ("step_peak_torque_nm", "{:.1f}"))
    figure_rows = [[f"**{c.name}**", *cells(results, cols, f"{c.name}_")] for c in contenders]
    text = [
        "# Exercise 4: switch to LQR",
        "",
        "*The tutorial: replace the PID with an LQR gain (from Day 3). Compare tracking accuracy.*",
        "",
        "The LQR here is designed at the control rate on each joint's `[∫e, e, ė]` (the arm `J ë + b ė = u` "
        "sampled with a zero-order hold, weights `lqr_q` on the state and `lqr_r` on the torque). The "
        "design's feedback `u = −K x` *is* a PID (`K = [Ki, Kp, Kd]`, derivative on the velocity error), so "
        "both laws can be put side by side gain by gain. Every run is the whole graph on sim time "
        f"(sensor seed {results['seed']}); figures on the TRUE angle." + (" **Quick form**." if quick else ""),
        "",
        "## The gains and the closed loop",
        "",
        table(
            "controller | Kp [N·m/rad] | Ki [N·m/(rad·s)] | Kd [N·m·s/rad] | "
            "closed-loop poles z (time constant or ωn, ζ) | largest |z| | gain margin [dB] | phase margin [°] | "
            "delay margin [periods]",
            gain_rows,
        ),
        "",
        "Poles: the eigenvalues of `A − B K` for the arm sampled every 10 ms. Inside the unit circle means "
        "stable; the closer to 1, the slower that part of the response dies away (a real pole z lasts "
        "about 10 ms / (1 − z)).",
        "",
        "## The figures",
        "",
        table(
            "controller | sine RMS error [rad] | sine max error [rad] | step overshoot [%] | settling 2 % [s] | "
            "rise 10–90 % [s] | steady-state error [rad] | peak torque [N·m]",
            figure_rows,
        ),
        "",
        f"Sine: 1 rad, 0.5 Hz, {plan['sine_s']:g} s, RMS after a 2 s warm-up. "
        f"Step: {results['step_rad']:g} rad, a jump, figures over the {plan['after_s']:g} s after it. "
        "The error is against the reference the controller used: "
        "the tutorial's planner publishes at 20 Hz and its controller holds each sample, hence the saw-tooth "
        "in the plot.",
        "",
        _verdict(results, analyses, contenders),
        "",
        "Plot: `lqr.png` (the steps, the sine's tracking error, the poles). Each run's bag and metrics are in "
        "the folders named after the controller.",
        "",
    ]
    return "\n".join(text)


def _pole_text(z: complex, dt: float = 0.01) -> str:
    wn, zeta = robustness.pole_summary(z, dt)
    if abs(z.imag) < 1e-9:
        tau = 1.0 / wn if wn > 0 else float("inf")
        return f"{z.real:.4f} (τ {tau:.3g} s)"
    return f"{z.real:.4f}{z.imag:+.4f}j (ωn {wn:.3g} rad/s, ζ {zeta:.2f})"


def _verdict(results: dict[str, Any], analyses: dict[str, dict[str, Any]], contenders) -> str:
    pid, lqr = results["pid_sine_tracking_rms_rad"], results["lqr_sine_tracking_rms_rad"]
    slow_pid = max(abs(p) for p in analyses["pid"]["poles"])
    words = [
        f"What it shows: in the same plumbing the LQR tracks the sine with {lqr * 1e3:.1f} mrad RMS, the "
        f"tutorial's PID with {pid * 1e3:.1f} mrad ({'better' if lqr < pid else 'worse'} by a factor "
        f"{max(pid, lqr) / min(pid, lqr):.2g})."
    ]
    words.append(
        f"The PID's slowest pole sits at z = {slow_pid:.4f}: its integral (Ki = "
        f"{analyses['pid']['ki']:g} against Kp = {analyses['pid']['kp']:g}) removes an error over "
        f"about {0.01 / max(1 - slow_pid, 1e-9):.1f} s, while the LQR's weights place every pole "
        f"at |z| ≤ {max(abs(p) for p in analyses['lqr']['poles']):.4f}."
    )
    if "lqr_default_sine_tracking_rms_rad" in results:
        default = results["lqr_default_sine_tracking_rms_rad"]
        words.append(
            f"The same LQR gains with model feedforward and the Kalman filter (the default stack) track "
            f"with {default * 1e3:.2f} mrad"
            + (
                ": most of the error left was the feedback having to produce, from an error, the torque "
                "the motion needs, which the arm model supplies in advance."
                if default < lqr
                else "."
            )
        )
    return " ".join(words)
