"""``robot-controller``'s parser (each verb's module and the ``robot_controller.verbs`` entry points add
their verbs) and entry point. A user's mistake is one line, exit 2; a failed run one line, exit 1; never a
traceback (a fault of ours writes its own into the run's folder)."""

from __future__ import annotations

import os
import sys
import tempfile
import traceback
from importlib.metadata import entry_points
from pathlib import Path

import robot_controller.cli.docs as docs
import robot_controller.cli.experiments as experiments
import robot_controller.cli.graph as graph
import robot_controller.cli.run as run
from robot_controller.cli.args import Parser, UsageError
from robot_controller.core.errors import ConfigError, RunFailed

#: The entry-point group whose functions ``add(subparsers)`` add their verbs (the project's lab does).
VERB_ENTRY_POINTS = "robot_controller.verbs"


def build_parser() -> Parser:
    parser = Parser(
        prog="robot-controller", description="run the loop, score a recording, experiment, and talk to a running graph"
    )
    sub = parser.add_subparsers(dest="verb", required=True, parser_class=Parser)
    run.register(sub)
    run.register_saved(sub)
    docs.register_params(sub)
    docs.register(sub, parser)
    experiments.register(sub)
    experiments.register_campaign(sub)
    graph.register(sub)
    for entry in sorted(entry_points(group=VERB_ENTRY_POINTS), key=lambda e: e.name):
        try:
            entry.load()(sub)
        except Exception as exc:  # noqa: BLE001 - another package's verbs must not break the CLI
            print(f"robot-controller: the verbs of {entry.value} were not added: {exc}", file=sys.stderr)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:  # said by the verb, as its other mistakes are
        print(f"robot-controller {args.verb}: unrecognized arguments: {' '.join(unknown)}", file=sys.stderr)
        return 2
    try:
        return args.handler(args)
    except (UsageError, ConfigError) as exc:  # one line, where MuJoCo's text spans several too
        print(f"robot-controller {args.verb}: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # `robot-controller params | head`
        return 0
    except OSError as exc:  # a path of the user's: missing, a directory, not writable
        where = f" {exc.filename}" if exc.filename else ""
        print(f"robot-controller {args.verb}:{where}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    except RunFailed as exc:
        print(f"robot-controller {args.verb}: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"robot-controller {args.verb}: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # noqa: BLE001 - a fault of ours: its traceback into a file, one line here
        out = getattr(args, "out", None)
        log = Path(out) / "error.log" if out else Path(tempfile.gettempdir()) / f"robot-controller-{args.verb}.log"
        try:
            log.parent.mkdir(parents=True, exist_ok=True)
            log.write_text(traceback.format_exc())
        except OSError:
            log = Path("(not written)")
        said = " ".join(str(exc).split())
        print(f"robot-controller {args.verb}: {type(exc).__name__}: {said} (traceback in {log})", file=sys.stderr)
        return 1


def entry() -> None:
    """The console script: ``main``, then exit without the interpreter's teardown of rclpy, MuJoCo
    and matplotlib (a third of a second of every run); every file is written and closed by then."""
    code = main()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)
