"""``robot-controller faults``: each node frozen mid-motion (SIGSTOP), and what the arm did."""

from __future__ import annotations

import argparse
from pathlib import Path

from robot_controller.cli.args import controller_option, out_option, robot_option, verb
from robot_controller.cli.output import StepProgress, output_dir, run_experiment


def register(sub) -> None:
    p = verb(sub, "faults", "freeze each node mid-motion (SIGSTOP) and measure what the arm did", faults)
    robot_option(p)
    controller_option(p)
    out_option(p, "runs/faults")
    p.add_argument("--quick", action="store_true", help="two cases: sensor and controller frozen 0.5 s")


def faults(a: argparse.Namespace) -> int:
    from robot_controller.experiments import faults as experiments

    out = output_dir(a.out, Path("runs/faults"))
    chosen = dict(quick=a.quick, robot=a.robot, controller=a.controller)

    def body(progress: StepProgress) -> None:
        experiments.faults(out, progress=progress, **chosen)

    return run_experiment("faults", len(experiments.cases(a.quick)), body, out / "faults.md")
