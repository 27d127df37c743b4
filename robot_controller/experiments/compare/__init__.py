"""The controller comparison (``robot-controller compare``): the contenders, one pair's runs
(``pairs``), the pairs side by side in worker processes (``workers``), the table (``report``)."""

from robot_controller.experiments.compare.comparison import COMPARE_WORKERS, compare
from robot_controller.experiments.compare.contenders import CONTENDERS, NAMED, Contender, contenders
from robot_controller.experiments.compare.pairs import COMPARED, IN_PROCESS_STEP_LEAD_S, loop_step_figures, run_pair
from robot_controller.experiments.compare.report import plot_compare, render_compare
from robot_controller.experiments.compare.workers import worker_domain

__all__ = [
    "COMPARED",
    "COMPARE_WORKERS",
    "CONTENDERS",
    "IN_PROCESS_STEP_LEAD_S",
    "NAMED",
    "Contender",
    "compare",
    "contenders",
    "loop_step_figures",
    "plot_compare",
    "render_compare",
    "run_pair",
    "worker_domain",
]
