"""``robot-controller``'s verbs for the loop itself: run, score, view, params and help."""

from __future__ import annotations

import argparse
from pathlib import Path

from robot_controller import verbs
from robot_controller.cli_options import port, positive_seconds, split_options, stack_options, verb
from robot_controller.verbs import UsageError


def loop_verbs(sub) -> None:
    p = verb(
        sub,
        "run",
        "run the five-node loop, record it and score it",
        lambda a: verbs.run(
            duration_s=a.duration,
            out=a.out,
            preset=a.preset,
            robot=a.robot,
            seed=a.seed,
            config=a.config,
            single_process=a.single_process,
            realtime=a.realtime,
            sim_time=a.sim_time,
            respawn=a.respawn,
            view_port=a.view_port if a.view else None,
            nodes=a.nodes,
            peers=a.peers,
            run_id=a.run_id,
            wait_s=a.wait,
        ),
    )
    p.add_argument("--duration", type=positive_seconds, default=20.0, help="seconds of control to record (default 20)")
    p.add_argument("--out", type=Path, help="output directory (default runs/<timestamp>)")
    stack_options(p)
    p.add_argument("--single-process", action="store_true", help="all five nodes on one executor")
    p.add_argument(
        "--sim-time",
        action="store_true",
        help="deterministic lockstep on /clock, as fast as the graph goes (--duration in sim seconds)",
    )
    p.add_argument(
        "--respawn",
        action="store_true",
        help="start a node that dies again (wall clock), as ros2 launch's respawn=True",
    )
    p.add_argument(
        "--realtime",
        action="store_true",
        help="run the simulator's pacing thread SCHED_FIFO, with a CPU budget (docs/controller.md)",
    )
    p.add_argument("--view", action="store_true", help="live 3D view and plots in the browser (rerun)")
    p.add_argument("--view-port", type=port, default=9090, help="port of the live view (default 9090)")
    split_options(p)
    p = verb(sub, "score", "re-score a run directory from its bag", lambda a: verbs.score(a.run_dir, as_json=a.json))
    p.add_argument("run_dir", type=Path)
    p.add_argument("--json", action="store_true", help="print the metrics as JSON")
    p = verb(
        sub,
        "view",
        "the 3D view and plots of a saved run, served in the browser",
        lambda a: verbs.view(a.run_dir, port=a.port, serve=not a.no_serve),
    )
    p.add_argument("run_dir", type=Path)
    p.add_argument("--port", type=port, default=9090, help="port (default 9090)")
    p.add_argument("--no-serve", action="store_true", help="only write DIR/view.rrd")
    p = verb(
        sub,
        "params",
        "list every node parameter with its default and meaning",
        _params,
    )
    p.add_argument(
        "--yaml", action="store_true", help="print the values as a ROS 2 parameter file (for --config or --params-file)"
    )
    p.add_argument(
        "--markdown",
        nargs="?",
        const="-",
        metavar="PATH",
        help="write the reference of every parameter (the schema's, the presets' and robots' changes) as Markdown, "
        "to PATH or stdout (docs/parameters.md)",
    )
    stack_options(p, seed=False)
    p = verb(sub, "help", "every verb's options and help", lambda a: _help(a.markdown))
    p.add_argument(
        "--markdown", nargs="?", const="-", metavar="PATH", help="as Markdown, to PATH or stdout (docs/cli.md)"
    )


def _params(a: argparse.Namespace) -> int:
    from robot_controller.robots import DEFAULT_ROBOT

    if a.markdown is None:
        return verbs.list_params(preset=a.preset, config=a.config, as_yaml=a.yaml, robot=a.robot)
    if a.yaml or a.config or a.preset != "default" or a.robot != DEFAULT_ROBOT:
        raise UsageError("--markdown documents the schema: it takes no --yaml, --preset, --robot or --config")
    from robot_controller import reference

    return reference.write(reference.parameters_markdown(), a.markdown, "params")


def _help(markdown: str | None) -> int:
    from robot_controller import reference
    from robot_controller.cli import build_parser  # the whole parser, every group's verbs

    parser = build_parser()
    if markdown is not None:
        return reference.write(reference.cli_markdown(parser), markdown, "help")
    print(parser.format_help())
    for name, _, sub in reference.subcommands(parser):
        print(f"--- {name} ---\n{sub.format_help()}")
    return 0
