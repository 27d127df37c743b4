"""``python -m robot_controller.cli``: the console script."""

from robot_controller.cli.main import entry

entry()
