"""The lab's verbs of ``robot-controller`` (``bench``, ``network``), added to its parser through the
``robot_controller.verbs`` entry point (pyproject.toml): the product never imports the lab."""

from __future__ import annotations

import argparse
from pathlib import Path

from robot_controller.cli.args import out_option, positive_seconds, verb
from robot_controller.cli.output import StepProgress, output_dir, run_experiment


def add_verbs(sub) -> None:
    p = verb(sub, "bench", "timing benchmark: jitter, latency, lockstep speed, core speed", bench)
    out_option(p, "runs/bench")
    p.add_argument("--quick", action="store_true", help="a few seconds per scenario")
    p.add_argument(
        "--soak-s", type=positive_seconds, help="length of the soak run, wall s (default 600, 20 with --quick)"
    )
    p = verb(
        sub,
        "network",
        "the loop split over two network namespaces: loss, a bandwidth cap, a cut link (needs root)",
        network,
    )
    out_option(p, "runs/network")
    p.add_argument("--quick", action="store_true", help="a short subset (the test suite's)")


def bench(a: argparse.Namespace) -> int:
    from robot_controller_lab import bench as timing

    out = output_dir(a.out, Path("runs/bench"))

    def body(progress: StepProgress) -> None:
        timing.bench(out, quick=a.quick, soak_s=a.soak_s, progress=progress)

    return run_experiment("bench", len(timing.SCENARIOS), body, out / "bench.md")


def network(a: argparse.Namespace) -> int:
    from robot_controller_lab.network import bench as network_bench

    return network_bench.main(output_dir(a.out, Path("runs/network")), quick=a.quick)
