"""Automatic gain design (``robot-controller tune``) for any law: the search (``search``), the margins
every tuned loop keeps (``margins``), a built-in law's problem on the batch harness (``analytic``) and a
law of one's own on the in-process loop (``blackbox``), each with its report; the verb (``procedure``)."""

from robot_controller.experiments.autotune.procedure import steps, tune

__all__ = ["steps", "tune"]
