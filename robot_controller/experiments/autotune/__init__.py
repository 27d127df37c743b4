"""Automatic gain design (``robot-controller tune``) for any law: the search (``search``), the margins
every tuned loop keeps (``margins``), a built-in law's problem on the batch harness (``analytic``) and a
law of one's own on the in-process loop (``blackbox``), each with its report; the verb (``procedure``)."""

from robot_controller.experiments.autotune.analytic import LQR_BOX, PID_BOX, AnalyticProblem, batch_tracking_rms
from robot_controller.experiments.autotune.blackbox import CASES, BlackBoxProblem, Case, Knob
from robot_controller.experiments.autotune.margins import (
    MAX_TIME_CONSTANT_S,
    MIN_DELAY_PERIODS,
    MIN_GAIN_MARGIN_DB,
    MIN_PHASE_MARGIN_DEG,
    UNCONDITIONALLY_STABLE,
    describe_margins,
)
from robot_controller.experiments.autotune.procedure import steps, tune
from robot_controller.experiments.autotune.search import SEED, Plan, SearchResult, latin_hypercube, search

__all__ = [
    "CASES",
    "LQR_BOX",
    "MAX_TIME_CONSTANT_S",
    "MIN_DELAY_PERIODS",
    "MIN_GAIN_MARGIN_DB",
    "MIN_PHASE_MARGIN_DEG",
    "PID_BOX",
    "SEED",
    "UNCONDITIONALLY_STABLE",
    "AnalyticProblem",
    "BlackBoxProblem",
    "Case",
    "Knob",
    "Plan",
    "SearchResult",
    "batch_tracking_rms",
    "describe_margins",
    "latin_hypercube",
    "search",
    "steps",
    "tune",
]
