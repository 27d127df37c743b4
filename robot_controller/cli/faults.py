"""``robot-controller faults``: each node frozen mid-motion (SIGSTOP), and what the arm did."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from robot_controller.cli.args import controller_option, out_option, robot_option, verb
from robot_controller.cli.output import StepProgress, output_dir, print_report


def register(sub) -> None:
    p = verb(sub, "faults", "freeze each node mid-motion (SIGSTOP) and measure what the arm did", faults)
    robot_option(p)
    controller_option(p)
    out_option(p, "runs/faults")
    p.add_argument("--quick", action="store_true", help="two cases: sensor and controller frozen 0.5 s")


def faults(a: argparse.Namespace) -> int:
    from robot_controller.experiments import faults as experiments

    out = output_dir(a.out, Path("runs/faults"))
    try:
        with StepProgress("faults", len(experiments.cases(a.quick))) as progress:
            experiments.faults(out, quick=a.quick, progress=progress, robot=a.robot, controller=a.controller)
    except (RuntimeError, ValueError, FileExistsError) as exc:
        print(f"robot-controller: {exc}", file=sys.stderr)
        return 1
    return print_report(out / "faults.md")
