"""``robot-controller exercise``: one of the tutorial's exercises as a reproducible experiment."""

from __future__ import annotations

import argparse
from pathlib import Path

from robot_controller.cli.args import UsageError, controller_option, out_option, verb
from robot_controller.cli.output import StepProgress, output_dir, run_experiment

# The exercises by name, for the parser (importing them would slow every verb's start).
EXERCISE_NAMES = ("tune", "disturbance", "windup", "lqr")
#: The exercises that take ``--controller`` (the law runs beside their own contenders).
EXERCISES_WITH_CONTROLLER = ("disturbance",)


def register(sub) -> None:
    p = verb(sub, "exercise", "one of the tutorial's exercises as a reproducible experiment", exercise)
    p.add_argument("name", choices=EXERCISE_NAMES)
    controller_option(p)  # exercise disturbance: the law runs beside the others
    out_option(p, "runs/exercise-NAME")
    p.add_argument("--quick", action="store_true", help="a short form (the test suite's)")


def exercise(a: argparse.Namespace) -> int:
    from robot_controller.experiments.exercises import EXERCISES, disturbance

    if a.controller is not None and a.name not in EXERCISES_WITH_CONTROLLER:
        raise UsageError(f"--controller: exercise {a.name} compares its own controllers; it applies to disturbance")
    out = output_dir(a.out, Path("runs") / f"exercise-{a.name}")
    chosen = EXERCISES[a.name]
    extra = {} if a.controller is None else {"controller": a.controller}
    # A law of one's own is one more contender of the disturbance exercise.
    steps = chosen.steps(a.quick) + (disturbance.RUNS_PER_CONTENDER if a.controller is not None else 0)

    def body(progress: StepProgress) -> None:
        chosen.run(out, quick=a.quick, progress=progress, **extra)

    return run_experiment(f"exercise {a.name}", steps, body, out / "report.md")
