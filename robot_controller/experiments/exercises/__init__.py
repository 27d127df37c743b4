"""The tutorial's exercises (``robot-controller exercise NAME --out DIR [--quick]``): each a module
with ``run(out, *, quick=False, progress=print)`` (writes ``report.md``, plots, ``results.json``) and
``steps(quick)`` (its progress calls), listed in ``catalogue``."""

from robot_controller.experiments.exercises.catalogue import EXERCISES, Exercise

__all__ = ["EXERCISES", "Exercise"]
