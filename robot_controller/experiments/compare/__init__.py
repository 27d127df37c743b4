"""The controller comparison (``robot-controller compare``): the contenders, one pair's runs
(``pairs``), the pairs side by side in worker processes (``workers``), the table (``report``)."""

from robot_controller.experiments.compare.comparison import COMPARE_WORKERS, compare
from robot_controller.experiments.compare.contenders import CONTENDERS, Contender, contenders

__all__ = ["COMPARE_WORKERS", "CONTENDERS", "Contender", "compare", "contenders"]
