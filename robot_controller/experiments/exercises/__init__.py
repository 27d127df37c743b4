"""The tutorial's exercises, each a reproducible experiment on the real graph
(``robot-controller exercise NAME --out DIR [--quick]``). Each is a module with
``run(out, *, quick=False, progress=print) -> dict`` (it writes ``report.md``, plots and
``results.json`` in ``out``) and ``steps(quick) -> int`` (how many times ``run`` calls
``progress``), listed in ``catalogue``."""

from robot_controller.experiments.exercises.catalogue import EXERCISES, Exercise, steps

__all__ = ["EXERCISES", "Exercise", "steps"]
