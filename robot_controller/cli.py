"""``robot-controller``: run the loop, score a recording, experiment, and talk
to a running graph.

Each verb is a plain function (in ``verbs``, ``verbs_experiments`` or ``verbs_graph``) returning
an exit code; here each subcommand only parses its arguments and names the
function it calls. A user's mistake is one line, exit 2, never a traceback.

Longer than our ~250-line guideline: one argument declaration per option of every verb.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable
from pathlib import Path

from robot_controller import parameters as cfg
from robot_controller import verbs, verbs_experiments, verbs_graph
from robot_controller.core.errors import ConfigError
from robot_controller.verbs import UsageError, output_dir


class Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # argparse's own: usage, then the error; here one line
        print(f"{self.prog}: {message}", file=sys.stderr)
        raise SystemExit(2)


def positive_seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (value > 0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text}")
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


def _verb(subparsers, name: str, help_text: str, handler: Handler) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(name, help=help_text, description=help_text)
    parser.set_defaults(handler=handler)
    return parser


def _robot_option(parser: argparse.ArgumentParser) -> None:
    from robot_controller.robots import DEFAULT_ROBOT, ROBOTS

    parser.add_argument(
        "--robot",
        default=DEFAULT_ROBOT,
        choices=sorted(ROBOTS),
        help=f"the arm: its URDF, limits, home pose and default trajectory (default {DEFAULT_ROBOT})",
    )


def _controller_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--controller",
        type=controller_spec,
        metavar="SPEC",
        help="the control law (pid_controller's controller_type): pid, lqr, an installed law, "
        "module:Class or path/to/file.py:Class",
    )


def _stack_options(parser: argparse.ArgumentParser, *, seed: bool = True) -> None:
    _robot_option(parser)
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


def _split_options(parser: argparse.ArgumentParser) -> None:
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


def _loop_verbs(sub) -> None:
    p = _verb(
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
    _stack_options(p)
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
    _split_options(p)
    p = _verb(sub, "score", "re-score a run directory from its bag", lambda a: verbs.score(a.run_dir, as_json=a.json))
    p.add_argument("run_dir", type=Path)
    p.add_argument("--json", action="store_true", help="print the metrics as JSON")
    p = _verb(
        sub,
        "view",
        "the 3D view and plots of a saved run, served in the browser",
        lambda a: verbs.view(a.run_dir, port=a.port, serve=not a.no_serve),
    )
    p.add_argument("run_dir", type=Path)
    p.add_argument("--port", type=port, default=9090, help="port (default 9090)")
    p.add_argument("--no-serve", action="store_true", help="only write DIR/view.rrd")
    p = _verb(
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
    _stack_options(p, seed=False)
    p = _verb(sub, "help", "every verb's options and help", lambda a: _help(a.markdown))
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

    parser = build_parser()
    if markdown is not None:
        return reference.write(reference.cli_markdown(parser), markdown, "help")
    print(parser.format_help())
    for name, _, sub in reference.subcommands(parser):
        print(f"--- {name} ---\n{sub.format_help()}")
    return 0


def _experiment_verbs(sub) -> None:
    p = _verb(
        sub,
        "step",
        "a step response: overshoot, rise, settling, steady-state error, torque",
        lambda a: verbs_experiments.step(
            amplitude=a.amplitude,
            shaping=a.shaping,
            out=a.out,
            preset=a.preset,
            robot=a.robot,
            seed=a.seed,
            config=a.config,
            sim_time=a.sim_time,
            controller=a.controller,
        ),
    )
    p.add_argument("--amplitude", type=float, default=0.5, help="step size, rad (default 0.5)")
    p.add_argument(
        "--shaping",
        default="min_time",
        choices=("min_time", "none"),
        help="shape the step into the fastest move within the acceleration limit (default), or jump",
    )
    p.add_argument("--out", type=Path)
    _stack_options(p)
    _controller_option(p)
    p.add_argument("--sim-time", action="store_true", help="deterministic lockstep")
    p = _verb(
        sub,
        "compare",
        "the tutorial preset, PID, PID+FF, PID+FF+Kalman, LQR on sine and step",
        lambda a: verbs_experiments.compare(
            out=output_dir(a.out, Path("runs/compare")),
            seeds=a.seeds,
            duration_s=a.duration,
            amplitude=a.amplitude,
            robot=a.robot,
            controllers=a.controllers,
            in_process=a.in_process,
        ),
    )
    _robot_option(p)
    p.add_argument(
        "--controllers",
        type=compare_entries,
        metavar="A,B,...",
        help="the entries compared: configurations (default, tutorial, pid, pid_ff, pid_ff_kf, lqr) or laws "
        "(module:Class, path/to/file.py:Class, an installed law) with the default stack (default: the configurations)",
    )
    p.add_argument("--in-process", action="store_true", help="on the in-process loop (no ROS): seconds, not minutes")
    p.add_argument("--out", type=Path, help="output directory (default runs/compare)")
    p.add_argument("--seeds", type=positive_int, default=5)
    p.add_argument("--duration", type=positive_seconds, default=10.0, help="sine duration, sim s (default 10)")
    p.add_argument("--amplitude", type=float, default=0.5, help="step size, rad")
    p = _verb(
        sub,
        "exercise",
        "one of the tutorial's exercises as a reproducible experiment",
        lambda a: verbs_experiments.exercise(
            a.name, output_dir(a.out, Path("runs") / f"exercise-{a.name}"), quick=a.quick, controller=a.controller
        ),
    )
    p.add_argument("name", choices=verbs_experiments.EXERCISE_NAMES)
    _controller_option(p)  # exercise disturbance: the law runs beside the others
    p.add_argument("--out", type=Path, help="output directory (default runs/exercise-NAME)")
    p.add_argument("--quick", action="store_true", help="a short form (the test suite's)")
    p = _verb(
        sub,
        "tune",
        "automatic gain design with robustness margins; writes tuned.yaml",
        lambda a: verbs_experiments.tune(
            output_dir(a.out, Path("runs/tune")),
            preset=a.preset,
            config=a.config,
            quick=a.quick,
            robot=a.robot,
            controller=a.controller,
        ),
    )
    p.add_argument("--out", type=Path, help="output directory (default runs/tune)")
    _stack_options(p, seed=False)
    _controller_option(p)  # a law of one's own: its gain=True parameters, searched on the in-process loop
    p.add_argument("--quick", action="store_true", help="a short search and short checks")
    p = _verb(
        sub,
        "identify",
        "identify the arm's inertia, damping, friction and gravity; writes identified.yaml",
        lambda a: verbs_experiments.identify(
            output_dir(a.out, Path("runs/identify")),
            preset=a.preset,
            robot=a.robot,
            config=a.config,
            seed=a.seed,
            duration_s=a.duration,
        ),
    )
    p.add_argument("--out", type=Path, help="output directory (default runs/identify)")
    _stack_options(p)
    p.add_argument("--duration", type=positive_seconds, default=20.0, help="excitation, sim s (default 20)")
    p = _verb(
        sub,
        "bench",
        "timing benchmark: jitter, latency, lockstep speed, core speed",
        lambda a: verbs_experiments.bench(output_dir(a.out, Path("runs/bench")), quick=a.quick, soak_s=a.soak_s),
    )
    p.add_argument("--out", type=Path, help="output directory (default runs/bench)")
    p.add_argument("--quick", action="store_true", help="a few seconds per scenario")
    p.add_argument(
        "--soak-s", type=positive_seconds, help="length of the soak run, wall s (default 600, 20 with --quick)"
    )
    p = _verb(
        sub,
        "faults",
        "freeze each node mid-motion (SIGSTOP) and measure what the arm did",
        lambda a: verbs_experiments.faults(
            output_dir(a.out, Path("runs/faults")), quick=a.quick, robot=a.robot, controller=a.controller
        ),
    )
    _robot_option(p)
    _controller_option(p)
    p.add_argument("--out", type=Path, help="output directory (default runs/faults)")
    p.add_argument("--quick", action="store_true", help="two cases: sensor and controller frozen 0.5 s")
    p = _verb(
        sub,
        "network",
        "the loop split over two network namespaces: loss, a bandwidth cap, a cut link (needs root)",
        lambda a: _network(a.out, a.quick),
    )
    p.add_argument("--out", type=Path, help="output directory (default runs/network)")
    p.add_argument("--quick", action="store_true", help="a short subset (the test suite's)")


def _network(out: Path | None, quick: bool) -> int:
    from robot_controller.network import bench

    return bench.main(output_dir(out, Path("runs/network")), quick=quick)


def _graph_verbs(sub) -> None:
    p = _verb(
        sub,
        "estop",
        "emergency stop of the running graph: torque off, brakes on, latched",
        lambda a: verbs_graph.estop(release=a.release),
    )
    p.add_argument("--release", action="store_true", help="release the e-stop; the loop re-acquires")
    p = _verb(
        sub,
        "disturb",
        "push the running arm: an external torque for a while (/sim/disturbance)",
        lambda a: verbs_graph.disturb(a.torque, a.duration, a.joint),
    )
    p.add_argument("--torque", type=float, required=True, help="N·m")
    p.add_argument("--duration", type=positive_seconds, default=0.5, help="s (default 0.5)")
    p.add_argument("--joint", help="joint name (default: every joint)")
    p = _verb(
        sub,
        "goto",
        "move the running arm to joint positions, at rest after --time (a JointTrajectory to the planner)",
        lambda a: verbs_graph.goto(a.positions, a.time, a.joints),
    )
    p.add_argument("positions", type=float, nargs="+", metavar="Q", help="rad, one per joint")
    p.add_argument("--time", type=positive_seconds, help="s to get there (default: from the distance, at least 1)")
    p.add_argument(
        "--joints", type=joint_list, help="names of the positions' joints, comma-separated (default: the arm's)"
    )
    p = _verb(
        sub,
        "trajectory",
        "send a joint trajectory from a YAML file to the running planner (joint_names, points)",
        lambda a: verbs_graph.send_trajectory(a.file),
    )
    p.add_argument("file", type=Path, help="YAML: joint_names: [...], points: [{time_from_start, positions}, ...]")
    topic = sub.add_parser("topic", help="ros2 topic's habits: list, echo, hz")
    topics = topic.add_subparsers(dest="topic_verb", required=True, parser_class=Parser)
    p = _verb(topics, "list", "the graph's topics", lambda a: verbs_graph.topic("list", show_types=a.show_types))
    p.add_argument("-t", "--show-types", action="store_true")
    p = _verb(
        topics,
        "echo",
        "print a topic's messages",
        lambda a: verbs_graph.topic("echo", a.topic, count=a.count, csv=a.csv),
    )
    p.add_argument("topic")
    p.add_argument("--count", type=positive_int, help="stop after this many messages")
    p.add_argument("--csv", action="store_true", help="one line of comma-separated values per message")
    p = _verb(
        topics,
        "hz",
        "a topic's rate",
        lambda a: verbs_graph.topic("hz", a.topic, window=a.window, duration_s=a.duration),
    )
    p.add_argument("topic")
    p.add_argument("--window", "-w", type=positive_int, default=10_000, help="messages the statistics cover")
    p.add_argument("--duration", type=positive_seconds, help="stop after this long, s (default: Ctrl-C)")
    param = sub.add_parser("param", help="ros2 param's habits: list, get, set, dump")
    params = param.add_subparsers(dest="param_verb", required=True, parser_class=Parser)
    p = _verb(params, "list", "a node's parameters", lambda a: verbs_graph.param("list", a.node))
    p.add_argument("node")
    p = _verb(params, "get", "one parameter's value", lambda a: verbs_graph.param("get", a.node, a.name))
    p.add_argument("node")
    p.add_argument("name")
    p = _verb(
        params,
        "set",
        "set one parameter (the node refuses a bad value with its reason)",
        lambda a: verbs_graph.param("set", a.node, a.name, a.value),
    )
    p.add_argument("node")
    p.add_argument("name")
    p.add_argument("value")
    p = _verb(
        params, "dump", "a node's parameters as a ROS 2 parameter file", lambda a: verbs_graph.param("dump", a.node)
    )
    p.add_argument("node")


def build_parser() -> Parser:
    parser = Parser(
        prog="robot-controller",
        description="run the loop, score a recording, experiment, and talk to a running graph",
    )
    sub = parser.add_subparsers(dest="verb", required=True, parser_class=Parser)
    _loop_verbs(sub)
    _experiment_verbs(sub)
    _graph_verbs(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
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
