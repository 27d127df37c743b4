"""``robot-controller tune``: gains designed for robustness margins, written as ``tuned.yaml``; a law of
one's own searched on the in-process loop."""

from __future__ import annotations

import argparse
from pathlib import Path

from robot_controller.cli.args import UsageError, controller_option, out_option, stack_options, verb
from robot_controller.cli.output import StepProgress, output_dir, run_experiment
from robot_controller.runner.options import RunOptions


def register(sub) -> None:
    p = verb(sub, "tune", "automatic gain design with robustness margins; writes tuned.yaml", tune)
    out_option(p, "runs/tune")
    stack_options(p, seed=False)
    controller_option(p)  # a law of one's own: its gain=True parameters, searched on the in-process loop
    p.add_argument("--quick", action="store_true", help="a short search and short checks")


def tune(a: argparse.Namespace) -> int:
    from robot_controller.experiments import autotune, laws
    from robot_controller.parameters import consistency

    params = laws.with_controller(RunOptions.from_args(a).params(), a.controller)
    consistency.check_stack(params)
    controller_type = params["pid_controller"]["controller_type"]
    if not laws.is_plugin(controller_type) and params["trajectory_planner"]["joint_count"] > 1:
        raise UsageError(
            f"--robot {a.robot}: tune designs one joint's gains; on a chain of joints the LQR's weights serve "
            "every joint, each scaled by its own inertia (lqr_q, lqr_r, reference_inertia)"
        )
    out = output_dir(a.out, Path("runs/tune"))

    def body(progress: StepProgress) -> None:
        autotune.tune(params, out, quick=a.quick, progress=progress)

    hint = f"use it with --config {out / 'tuned.yaml'}"
    return run_experiment("tune", autotune.steps(a.quick, controller_type), body, out / "report.md", hint)
