"""``robot-controller compare``: configurations and laws side by side on a sine and a step."""

from __future__ import annotations

import argparse
from pathlib import Path

from robot_controller.cli.args import (
    compare_entries,
    out_option,
    positive_int,
    positive_seconds,
    robot_option,
    step_size_rad,
    verb,
)
from robot_controller.cli.output import output_dir, run_experiment


def register(sub) -> None:
    p = verb(sub, "compare", "the tutorial preset, PID, PID+FF, PID+FF+Kalman, LQR on sine and step", compare)
    robot_option(p)
    p.add_argument(
        "--controllers",
        type=compare_entries,
        metavar="A,B,...",
        help="the entries compared: configurations (default, tutorial, pid, pid_ff, pid_ff_kf, lqr) or laws "
        "(module:Class, path/to/file.py:Class, an installed law) with the default stack (default: the configurations)",
    )
    p.add_argument("--in-process", action="store_true", help="on the in-process loop (no ROS): seconds, not minutes")
    out_option(p, "runs/compare")
    p.add_argument("--seeds", type=positive_int, default=5)
    p.add_argument("--duration", type=positive_seconds, default=10.0, help="sine duration, sim s (default 10)")
    p.add_argument("--amplitude", type=step_size_rad, default=0.5, help="step size, rad")


def compare(a: argparse.Namespace) -> int:
    from robot_controller.experiments import compare as experiments

    out = output_dir(a.out, Path("runs/compare"))
    steps = len(experiments.contenders(a.controllers)) * a.seeds
    chosen = dict(seeds=a.seeds, sine_duration_s=a.duration, amplitude=a.amplitude, robot=a.robot)
    chosen.update(controllers=a.controllers, in_process=a.in_process)
    return run_experiment(
        "compare", steps, lambda progress: experiments.compare(out, progress=progress, **chosen), out / "compare.md"
    )
