"""``robot-controller run``: the five-node loop, recorded and scored; part of it across hosts."""

from __future__ import annotations

import argparse
import datetime as dt
import signal
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
from robot_controller.cli.output import effort_limits, output_dir, print_summary, say_arm, typed_command
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
        "--sim-time": f"deterministic lockstep on {spec.CLOCK.topic}, as fast as the graph goes "
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
    wait_help = "give up if the whole graph is not there within S seconds (default 60)"
    p.add_argument("--wait", dest="wait_s", type=positive_seconds, default=60.0, metavar="S", help=wait_help)


def _run(args: argparse.Namespace) -> int:
    paced = not (args.sim_time or args.wall_clock)
    return run(replace(RunOptions.from_args(args), paced=paced), args.out)


def run(options: RunOptions, out: Path | None) -> int:
    """Run, record and score the loop (part of the graph without the simulator: say what it ran)."""
    from robot_controller import robots
    from robot_controller.core import metrics
    from robot_controller.runner import launcher, plan
    from robot_controller.scoring import plots, report, summary, verdict

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
    options = checked.options  # a split or respawning run keeps the wall clock
    sim_time, duration_s = options.lockstep, options.duration_s
    try:
        recording = report.read_recording(result.bag_dir)
        units = report.arm_units(checked.params["simulator"]["urdf_path"])
        period_s = 1.0 / checked.params["pid_controller"]["control_rate_hz"]
        window_s = duration_s if sim_time else None
        # On the wall clock, or interrupted, the nodes stop one by one after the run: the stops that follow (a
        # controller gone before the drive's timeout) are not the run's.
        judged_s = result.control_seconds if result.interrupted or not sim_time else None
        values = report.score(
            recording,
            nominal_period_s=period_s,
            window_s=window_s,
            units=units,
            receipts=not options.sim_time,
            judged_s=judged_s,
        )
    except ValueError as exc:
        # A run that already failed said FAILED and why: its verdict stays one line.
        launcher.say(f"{'' if result.exit_code else 'FAILED: '}cannot score the recording: {exc}")
        return result.exit_code or 1
    recorded_s = result.control_seconds if result.interrupted or not sim_time else duration_s
    if sim_time and result.failure is not None and values.get("recorded_duration_s") is not None:
        recorded_s = min(recorded_s, values["recorded_duration_s"])  # ended early: the ticks' own span (seeded)
    robot = robots.arm_name(options.robot, checked.params["simulator"]["urdf_path"])
    preset, seed = options.preset, options.seed
    values.update(duration_s=round(recorded_s, 3), interrupted=result.interrupted, preset=preset, robot=robot)
    values.update(seed=seed, mode="single_process" if options.single_process else "multi_process")
    values.update(clock="sim_paced" if options.paced else "sim_lockstep" if sim_time else "wall")
    if options.nodes is not None and len(result.local_nodes) < 5:  # a split run: what ran here (the rest elsewhere)
        values["nodes_here"] = ",".join(result.local_nodes)
    # Wall-clock figures of a lockstep run differ run to run: keep them out of metrics.json.
    wall = {"real_time_factor": result.real_time_factor, "wall_duration_s": result.wall_seconds}
    # How many messages the bag misses depends on when the nodes stopped, not on the seed.
    (wall if sim_time else values)["unrecorded_messages"] = sum(result.unrecorded.values())
    if options.sim_time:
        wall.update(result.usage)
    else:  # a paced world's freezes and its loop's late efforts, or the wall clock's
        values.update(result.world_clock)
        # Periods the host stretched (the loop waited for a CPU): not the loop's own misses, among those scored.
        host_missed = metrics.periods_ending_within(result.host_missed_ends_s, recording.state["time_s"])
        if host_missed:
            values["missed_cycles_host"] = host_missed
            values["missed_cycles"] = max(0, values.get("missed_cycles", 0) - host_missed)
        # Watchdog ticks the host made (the readings' silence past the window was its doing): counted apart.
        if host_watchdog := metrics.periods_ending_within(result.host_watchdog_s, recording.state["time_s"]):
            values["watchdog_ticks_host"] = host_watchdog
            values["watchdog_ticks"] = max(0, values.get("watchdog_ticks", 0) - host_watchdog)
        values.update(result.clocks)  # a split run's hosts' clock offset
        values["realtime_requested"] = options.realtime
        values.update(result.usage)
    if options.paced:
        values.update(wall)  # not the same run to run: the host's
    band_rad = options.tracking_band_rad or robots.robot(options.robot).tracking_band_rad
    failure = result.failure if result.exit_code else None
    judged = verdict.judge(values, band_rad=band_rad, failure=failure)
    # The run's own failure (a node died, the law failed), apart from a verdict on a run that ran: both exit 1.
    values.update(judged.as_metrics(), tracking_band_rad=band_rad, run_failure=failure)
    report.write_metrics(out / "metrics.json", values)
    if options.sim_time:
        report.write_metrics(out / "timing.json", wall)
    plots.plot_tracking(recording, out / "tracking.png", title=f"{robot}, preset {preset}, seed {seed}", units=units)
    limits = effort_limits(checked.params, len(units))
    rows = summary.run_rows(values | (wall if options.sim_time else {}), effort_limits=limits, out=str(out))
    links = ["tracking.png", "bag/", "metrics.json", "params.yaml"]
    text = summary.markdown(judged.line, rows, title=f"Run {out.name}", command=typed_command(), links=links)
    (out / "summary.md").write_text(text)
    print_summary(judged.line, rows)
    return result.exit_code or (0 if judged.ok else 1)
