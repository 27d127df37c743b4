"""``robot-controller``: run the loop, score a recording, experiment, and talk to a running graph.
Each verb's options and body are in one module here; ``main`` builds the parser from them."""

from robot_controller.cli.main import build_parser, entry, main

__all__ = ["build_parser", "entry", "main"]
