"""What every verb of ``robot-controller`` parses with: the parser whose errors
are one line (exit 2), the argument types that check a value as it is read, and
the option groups several verbs share (the robot, the stack, the law, part of
the graph across hosts).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError


class Parser(argparse.ArgumentParser):
    def __init__(self, *args, **kwargs) -> None:
        # No abbreviations: `--sim` must not quietly mean `--sim-time` (nor a later option's prefix).
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message: str) -> None:  # argparse's own: usage, then the error; here one line
        print(f"{self.prog}: {message}", file=sys.stderr)
        raise SystemExit(2)


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None


def positive_seconds(text: str) -> float:
    value = _number(text)
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


def step_size_rad(text: str) -> float:
    """A step's size: finite and not zero (a step of nothing has no response to measure)."""
    value = _number(text)
    if not (abs(value) > 0 and abs(value) < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number other than 0, got {text}")
    return value


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {text}")
    return value


def joint_list(text: str) -> list[str]:
    names = [name.strip() for name in text.split(",")]
    if not all(names):
        raise argparse.ArgumentTypeError(f"expected comma-separated joint names, got {text!r}")
    return names


def port(text: str) -> int:
    value = positive_int(text)
    if value > 65535:
        raise argparse.ArgumentTypeError(f"not a TCP port: {text}")
    return value


def controller_spec(text: str) -> str:
    """A law as ``controller_type`` names it, loaded now: a bad one is argparse's one line."""
    from robot_controller.experiments import laws

    try:
        laws.controller_type(text)
    except ConfigError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("--controller: ")) from None
    return text.strip()


def compare_entries(text: str) -> list[str]:
    """``compare --controllers``: configurations and laws, comma-separated, each checked now."""
    from robot_controller.experiments.compare import contenders

    names = [name.strip() for name in text.split(",")]
    try:
        contenders(names)
    except ConfigError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix("--controllers: ")) from None
    return names


Handler = Callable[[argparse.Namespace], int]


def verb(subparsers, name: str, help_text: str, handler: Handler) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(name, help=help_text, description=help_text)
    parser.set_defaults(handler=handler)
    return parser


def robot_option(parser: argparse.ArgumentParser) -> None:
    from robot_controller.robots import DEFAULT_ROBOT, ROBOTS

    parser.add_argument(
        "--robot",
        default=DEFAULT_ROBOT,
        choices=sorted(ROBOTS),
        help=f"the arm: its URDF, limits, home pose and default trajectory (default {DEFAULT_ROBOT})",
    )


def controller_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--controller",
        type=controller_spec,
        metavar="SPEC",
        help="the control law (pid_controller's controller_type): pid, lqr, an installed law, "
        "module:Class or path/to/file.py:Class",
    )


def stack_options(parser: argparse.ArgumentParser, *, seed: bool = True) -> None:
    robot_option(parser)
    parser.add_argument("--preset", default="default", choices=cfg.available_presets())
    parser.add_argument(
        "--config",
        type=Path,
        action="append",
        help="ROS 2 parameter file layered over the preset (repeatable: later files over earlier)",
    )
    if seed:
        parser.add_argument("--seed", type=int, default=0, help="sensor noise seed (default 0)")


def node_list(text: str) -> tuple[str, ...]:
    from robot_controller.runner.plan import check_nodes

    try:
        return check_nodes(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def peer_list(text: str) -> list[str]:
    from robot_controller.ros.partition import check_peers

    try:
        return check_peers(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def run_name(text: str) -> str:
    from robot_controller.ros.partition import check_run_id

    try:
        return check_run_id(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def split_options(parser: argparse.ArgumentParser) -> None:
    """``run``'s options for part of the graph, across hosts (docs/design.md §6, "Across hosts")."""
    parser.add_argument(
        "--nodes",
        type=node_list,
        metavar="A,B,...",
        help="start only these of simulator, motor_node, sensor_node, pid_controller, trajectory_planner "
        "(default all); the launcher with the simulator records and scores",
    )
    parser.add_argument(
        "--peers",
        type=peer_list,
        metavar="ADDR[,ADDR]",
        help="the other hosts' IPv4 addresses: discovery by unicast to them, UDPv4 only (no shared memory)",
    )
    parser.add_argument("--run-id", type=run_name, metavar="NAME", help="the run's name, the same on every launcher")
    parser.add_argument(
        "--wait",
        type=positive_seconds,
        default=60.0,
        metavar="S",
        help="give up if the whole graph is not there within S seconds (default 60)",
    )
