"""What every verb of ``robot-controller`` parses with: the parser whose errors are one line (exit 2),
the argument types that check a value as it is read, and the option groups several verbs share."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError
from robot_controller.ros import partition
from robot_controller.runner.options import check_nodes


class UsageError(Exception):
    """A mistake of the user's: one line on stderr, exit code 2."""


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


def positive_float(text: str) -> float:
    if not 0 < (value := _number(text)) < float("inf"):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
    return value


positive_seconds = positive_float


def step_size_rad(text: str) -> float:
    """A step's size: finite and not zero (a step of nothing has no response to measure)."""
    if not 0 < abs(value := _number(text)) < float("inf"):
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


def _checked(check: Callable[[str], object], prefix: str = "") -> Callable[[str], object]:
    """An argument type of ``check``: its ``ValueError`` (or ``ConfigError``) is argparse's one line."""

    def parse(text: str) -> object:
        try:
            return check(text)
        except (ValueError, ConfigError) as exc:
            raise argparse.ArgumentTypeError(str(exc).removeprefix(prefix)) from None

    return parse


def _controller(text: str) -> str:
    from robot_controller.experiments import laws

    laws.controller_type(text)  # loaded now
    return text.strip()


def _compare_entries(text: str) -> list[str]:
    from robot_controller.experiments.compare import contenders

    names = [name.strip() for name in text.split(",")]
    contenders(names)  # each checked now
    return names


controller_spec = _checked(_controller, "--controller: ")  #: a law as ``controller_type`` names it
compare_entries = _checked(_compare_entries, "--controllers: ")  #: configurations and laws, comma-separated
node_list = _checked(check_nodes)
peer_list = _checked(partition.check_peers)
run_name = _checked(partition.check_run_id)

Handler = Callable[[argparse.Namespace], int]


def verb(subparsers, name: str, help_text: str, handler: Handler) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(name, help=help_text, description=help_text)
    parser.set_defaults(handler=handler)
    return parser


def robot_option(parser: argparse.ArgumentParser) -> None:
    from robot_controller.robots import DEFAULT_ROBOT

    parser.add_argument(
        "--robot",
        default=DEFAULT_ROBOT,
        metavar="NAME|PATH",
        help="the arm: its URDF, limits, home pose and default trajectory; a name of `robot-controller robots`, "
        f"a URDF or MJCF file or a package:// URI (default {DEFAULT_ROBOT})",
    )


def controller_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--controller",
        type=controller_spec,
        metavar="SPEC",
        help="the control law (pid_controller's controller_type): pid, lqr, an installed law, "
        "module:Class or path/to/file.py:Class",
    )


def out_option(parser: argparse.ArgumentParser, default: str | None) -> None:
    parser.add_argument("--out", type=Path, help=f"output directory (default {default})" if default else None)


def stack_options(parser: argparse.ArgumentParser, *, seed: bool = True) -> None:
    """The stack a verb loads (``RunOptions``' ``robot``, ``preset``, ``config``, ``seed``)."""
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
