"""``robot-controller identify``: the arm's inertia, damping, friction and gravity from an excitation
run, written as ``identified.yaml``."""

from __future__ import annotations

import argparse
from pathlib import Path

from robot_controller.cli.args import out_option, positive_seconds, stack_options, verb
from robot_controller.cli.output import StepProgress, output_dir, run_experiment
from robot_controller.runner.options import RunOptions


def register(sub) -> None:
    p = verb(
        sub, "identify", "identify the arm's inertia, damping, friction and gravity; writes identified.yaml", identify
    )
    out_option(p, "runs/identify")
    stack_options(p)
    p.add_argument("--duration", type=positive_seconds, default=20.0, help="excitation, sim s (default 20)")


def identify(a: argparse.Namespace) -> int:
    from robot_controller.experiments import identify as experiments
    from robot_controller.parameters import consistency

    options = RunOptions.from_args(a)
    params = options.params()
    consistency.check_stack(params)
    out = output_dir(a.out, Path("runs/identify"))
    hint = f"use it with --config {out / 'identified.yaml'} (after your other --config files)"

    def body(progress: StepProgress) -> None:
        experiments.identify(params, out, duration_s=a.duration, seed=options.seed, progress=progress)

    return run_experiment("identify", 4, body, out / "identification.md", hint)
