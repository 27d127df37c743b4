"""``robot-controller``: run the loop, score a recording, experiment, and talk
to a running graph.

Each verb is a plain function (in ``verbs``, ``verbs_experiments`` or
``verbs_graph``) returning an exit code; its subcommand only parses its
arguments and names the function it calls. A user's mistake is one line,
exit 2, never a traceback.

The subcommands are declared per group: the loop's (``cli_loop``), the
experiments' (``cli_experiments``) and the running graph's (``cli_graph``), on
the argument types and shared options of ``cli_options``.
"""

from __future__ import annotations

import os
import sys

from robot_controller.cli_experiments import experiment_verbs
from robot_controller.cli_graph import graph_verbs
from robot_controller.cli_loop import loop_verbs
from robot_controller.cli_options import Parser
from robot_controller.core.errors import ConfigError
from robot_controller.verbs import UsageError


def build_parser() -> Parser:
    parser = Parser(
        prog="robot-controller",
        description="run the loop, score a recording, experiment, and talk to a running graph",
    )
    sub = parser.add_subparsers(dest="verb", required=True, parser_class=Parser)
    loop_verbs(sub)
    experiment_verbs(sub)
    graph_verbs(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:  # said by the verb, as its other mistakes are
        print(f"robot-controller {args.verb}: unrecognized arguments: {' '.join(unknown)}", file=sys.stderr)
        return 2
    try:
        return args.handler(args)
    except (UsageError, ConfigError) as exc:
        print(f"robot-controller {args.verb}: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # `robot-controller params | head`
        return 0
    except OSError as exc:  # a path of the user's: missing, a directory, not writable
        where = f" {exc.filename}" if exc.filename else ""
        print(f"robot-controller {args.verb}:{where}: {exc.strerror or exc}", file=sys.stderr)
        return 2


def entry() -> None:
    """The console script: ``main``, then exit without the interpreter's
    teardown of rclpy, MuJoCo and matplotlib (a third of a second of every
    run); every file is written and closed by then."""
    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)


if __name__ == "__main__":
    entry()
