"""The tutorial's exercises, each automated as a reproducible experiment on the
real graph (``robot-controller exercise NAME --out DIR [--quick]``).

Each exercise is a module with ``run(out, *, quick=False, progress=print) -> dict``
(it writes ``report.md``, plots and ``results.json`` in ``out``, and returns
the results) and ``steps(quick) -> int``, the number of times ``run`` calls
``progress`` (one call as each step starts, for a progress bar). ``quick`` is a
short form for the test suite.

To add one: a module beside these with an
``EXERCISE = Exercise(name, title, run, steps)``, listed in ``EXERCISES`` below.
"""

from __future__ import annotations

from robot_controller.experiments.exercises import disturbance, lqr, windup, ziegler_nichols
from robot_controller.experiments.exercises.common import Exercise

#: Every exercise by name, in the tutorial's order.
EXERCISES: dict[str, Exercise] = {
    module.EXERCISE.name: module.EXERCISE for module in (ziegler_nichols, disturbance, windup, lqr)
}


def steps(name: str, quick: bool = False) -> int:
    """How many progress steps ``EXERCISES[name].run`` takes (``quick`` or full)."""
    return EXERCISES[name].steps(quick)


__all__ = ["EXERCISES", "Exercise", "steps"]
