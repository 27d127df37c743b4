"""A run's verbs: ``run`` the five-node loop, recorded and scored (part of it across hosts); ``score`` re-scores a
saved run's bag; ``view`` serves its 3D view and plots."""

from __future__ import annotations

import argparse
import datetime as dt
import json
import signal
import sys
from dataclasses import replace
from pathlib import Path

from robot_controller.blocks import spec
from robot_controller.cli.args import (
    node_list,
    out_option,
    peer_list,
    port,
    positive_float,
    positive_seconds,
    run_name,
    stack_options,
    verb,
)
from robot_controller.cli.output import output_dir, print_summary, print_table, say_arm, typed_command
from robot_controller.runner.options import RunOptions


def register(sub) -> None:
    p = verb(sub, "run", "run the five-node loop, record it and score it", _run)
    duration_help = "seconds of control to record (default 20)"
    p.add_argument(
        "--duration", dest="duration_s", metavar="DURATION", type=positive_seconds, default=20.0, help=duration_help
    )
    out_option(p, "runs/<timestamp>")
    stack_options(p)
    p.add_argument("--single-process", action="store_true", help="all five nodes on one executor")
    flags = {
        "--sim-time": f"deterministic, on the sim's clock ({spec.CLOCK.topic}), as fast as the graph goes "
        "(--duration in sim seconds)",
        "--wall-clock": "hardware-strict: the drive on this host's clock, any late command refused, a host freeze "
        "the loop's fault (default: the world's clock keeps pace with the wall clock and pauses with the host)",
        "--respawn": "start a node that dies again (wall clock), as ros2 launch's respawn=True",
        "--realtime": "run the simulator's pacing thread SCHED_FIFO, with a CPU budget (docs/controller.md)",
    }
    for flag, flag_help in flags.items():
        p.add_argument(flag, action="store_true", help=flag_help)
    p.add_argument("--view", action="store_true", help="live 3D view and plots in the browser (rerun)")
    p.add_argument("--view-port", type=port, default=9090, help="port of the live view (default 9090)")
    # Part of the graph, across hosts (docs/design.md §6, "Across hosts").
    p.add_argument(
        "--nodes",
        type=node_list,
        metavar="A,B,...",
        help="start only these of simulator, motor_node, sensor_node, pid_controller, trajectory_planner "
        "(default all); the launcher with the simulator records and scores",
    )
    p.add_argument(
        "--peers",
        type=peer_list,
        metavar="ADDR[,ADDR]",
        help="the other hosts' IPv4 addresses: discovery by unicast to them, UDPv4 only (no shared memory)",
    )
    p.add_argument("--run-id", type=run_name, metavar="NAME", help="the run's name, the same on every launcher")
    band_help = (
        "how far (rad; m on a prismatic joint) the arm may be from its reference, start included, for the run to be "
        "ok (default: the robot's, 0.02)"
    )
    p.add_argument("--tracking-band", dest="tracking_band_rad", type=positive_float, metavar="RAD", help=band_help)
    hardware_help = (
        "run on a robot instead of the simulator: franka://HOST, a Franka arm through libfranka in torque control at "
        "1 kHz (a stand-in: make franka-sim; docs/hardware.md)"
    )
    p.add_argument("--hardware", metavar="URL", help=hardware_help)
    sensing_help = (
        "what the controller measures the arm with: encoders (the sensor_node's, default), camera (a rendered camera "
        "and markers on every link: camera_node, and the vision in sensor_node), or both (the camera's readings "
        "fused with the encoders' by the controller's filter; docs/camera.md)"
    )
    p.add_argument("--sensing", choices=SENSING, help=sensing_help)
    wait_help = "give up if the whole graph is not there within S seconds (default 60)"
    p.add_argument("--wait", dest="wait_s", type=positive_seconds, default=60.0, metavar="S", help=wait_help)


#: ``--sensing``'s choices (``runner.sensing``)
SENSING = ("encoders", "camera", "both")


def _run(args: argparse.Namespace) -> int:
    paced = not (args.sim_time or args.wall_clock or args.hardware)
    return run(replace(RunOptions.from_args(args), paced=paced), args.out)


def run(options: RunOptions, out: Path | None) -> int:
    """Run, record and score the loop (part of the graph without the simulator: say what it ran)."""
    from robot_controller.runner import launcher, plan
    from robot_controller.scoring import scored_run

    checked = plan.check(options.params(), options)  # before the output folder is made
    say_arm(options.robot)
    out = output_dir(out, Path("runs") / dt.datetime.now().strftime("%Y%m%d-%H%M%S"))
    result = launcher.launch(checked, out)
    if not result.recorded:  # the other launcher records and scores the loop
        if result.end_reason is not None:
            ran = f"ran {', '.join(result.local_nodes)} for {result.wall_seconds:.1f} s; {result.end_reason}"
            launcher.say(f"{ran} (the launcher with the simulator recorded and scored it)")
        return result.exit_code
    if result.interrupted:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # scoring takes a second: let it finish
    if result.exit_code != 0 and not any(result.message_counts.values()):
        return result.exit_code
    try:
        scored = scored_run.score_launched(checked, result)
    except ValueError as exc:
        # A run that already failed said FAILED and why: its verdict stays one line.
        launcher.say(f"{'' if result.exit_code else 'FAILED: '}cannot score the recording: {exc}")
        return result.exit_code or 1
    scored.write(out, command=typed_command())
    print_summary(scored.verdict.line, scored.rows(out))
    # The run's own failure (a node died, the law failed), apart from a verdict on a run that ran: both exit 1.
    return result.exit_code or (0 if scored.verdict.ok else 1)


def register_saved(sub) -> None:
    p = verb(
        sub,
        "score",
        "re-score a run directory from its bag and judge it against the band it ran with (exit 1 if FAILED)",
        lambda a: score(a.run_dir, as_json=a.json, every_figure=a.all),
    )
    p.add_argument("run_dir", type=Path)
    p.add_argument("--json", action="store_true", help="print the metrics as JSON")
    p.add_argument("--all", action="store_true", help="print every figure as a table (default: the dozen that matter)")
    p = verb(
        sub,
        "view",
        "the 3D view and plots of a saved run, served in the browser",
        lambda a: view(a.run_dir, port=a.port, serve=not a.no_serve),
    )
    p.add_argument("run_dir", type=Path)
    p.add_argument("--port", type=port, default=9090, help="port (default 9090)")
    p.add_argument("--no-serve", action="store_true", help="only write DIR/view.rrd")


def score(run_dir: Path, *, as_json: bool = False, every_figure: bool = False) -> int:
    from robot_controller.scoring import report, scored_run

    try:
        scored = scored_run.rescore(run_dir)
    except (FileNotFoundError, ValueError) as exc:
        print(f"robot-controller: cannot score {run_dir}: {exc}", file=sys.stderr)
        return 2
    if as_json:
        print(json.dumps(report.json_safe(scored.judged), indent=2, sort_keys=True))
    elif every_figure:
        print_table(scored.judged, title=f"re-scored {run_dir / 'bag'}")
        print_summary(scored.verdict.line, [])
    else:  # the run's facts (robot, clock, host freezes) from its metrics.json, the figures re-scored
        rows = scored.rows()
        print(f"re-scored {run_dir / 'bag'}")
        print_summary(scored.verdict.line, [*rows, ("all figures", f"robot-controller score {run_dir} --all")])
    return 0 if scored.verdict.ok else 1


def view(run_dir: Path, *, port: int, serve: bool) -> int:
    from robot_controller.view.from_bag import build_view_from_bag

    build_view_from_bag(run_dir, port, serve)
    return 0
