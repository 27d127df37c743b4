"""The verbs of ``robot-controller``, each a plain function taking typed
arguments and returning an exit code (``cli`` only parses and dispatches).
A user's mistake raises ``UsageError`` or ``ConfigError``: one line, exit 2.

The loop's own verbs are here (run, score, view, params) with what every verb
shares (``output_dir``, ``print_table``); the experiments' are in
``verbs_experiments``, those that talk to a running graph in ``verbs_graph``.
"""

from __future__ import annotations

import datetime as dt
import json
import os
import signal
import sys
from pathlib import Path

from robot_controller import parameters as cfg
from robot_controller.parameters import consistency as config_check


class UsageError(Exception):
    """A mistake of the user's: one line on stderr, exit code 2."""


# What marks a directory as holding results already.
RESULT_FILES = ("params.yaml", "bag", "metrics.json", "bench.json", "compare.json", "faults.json", "report.md")


def output_dir(out: Path | None, default: Path) -> Path:
    """Where a verb writes. An ``--out`` that holds results is refused (nothing is
    overwritten); the default location, if used already, becomes a fresh
    sibling (``runs/faults-2``), said on screen."""
    chosen = out if out is not None else default
    if chosen.exists() and not chosen.is_dir():
        raise UsageError(f"--out {chosen}: exists and is not a directory")
    if chosen.is_dir() and any((chosen / name).exists() for name in RESULT_FILES):
        if out is not None:
            raise UsageError(f"--out {chosen}: holds an earlier run; choose another directory (nothing was changed)")
        n = 2
        while (chosen.parent / f"{chosen.name}-{n}").exists():
            n += 1
        chosen = chosen.parent / f"{chosen.name}-{n}"
        print(f"robot-controller: {default} holds an earlier run: writing to {chosen}", file=sys.stderr)
    try:
        chosen.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"--out {chosen}: cannot create it ({exc.strerror})") from None
    if not os.access(chosen, os.W_OK | os.X_OK):
        raise UsageError(f"--out {chosen}: not writable")
    return chosen


HEADLINE = (
    "tracking_rms_rad",
    "tracking_max_rad",
    "measured_rms_rad",
    "control_rate_hz",
    "jitter_p99_ms",
    "missed_cycles",
    "latency_p50_ms",
    "latency_p99_ms",
    "peak_torque_nm",
    "duration_s",
    "real_time_factor",
)


def run(
    *,
    duration_s: float,
    out: Path | None,
    preset: str,
    seed: int,
    config: list[Path] | None,
    single_process: bool,
    robot: str = "one_dof",
    realtime: bool = False,
    sim_time: bool = False,
    respawn: bool = False,
    view_port: int | None = None,
    nodes: tuple[str, ...] | None = None,
    peers: list[str] | None = None,
    run_id: str | None = None,
    wait_s: float | None = None,
) -> int:
    """``nodes``/``peers``/``run_id``/``wait_s``: part of the graph, across hosts
    (docs/design.md §6): the launcher with the simulator records and scores as
    always; one without it records nothing and says what it ran."""
    from robot_controller.runner import launcher, supervise
    from robot_controller.scoring import plots, report

    params = cfg.load_stack(preset, config, robot)
    params["sensor_node"]["seed"] = seed
    config_check.check_stack(params)  # before the output folder is made
    out = output_dir(out, Path("runs") / dt.datetime.now().strftime("%Y%m%d-%H%M%S"))
    result = launcher.launch(
        params,
        out_dir=out,
        duration_s=duration_s,
        single_process=single_process,
        realtime=realtime,
        sim_time=sim_time,
        respawn=respawn,
        view_port=view_port,
        nodes=nodes,
        peers=peers,
        run_id=run_id,
        wait_s=supervise.GRAPH_WAIT_S if wait_s is None else wait_s,
    )
    if not result.recorded:  # the other launcher records and scores the loop
        if result.end_reason is not None:
            launcher.say(
                f"ran {', '.join(result.local_nodes)} for {result.wall_seconds:.1f} s; {result.end_reason} "
                "(the launcher with the simulator recorded and scored it)"
            )
        return result.exit_code
    if result.interrupted:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # scoring takes a second: let it finish
    if result.exit_code != 0 and not any(result.message_counts.values()):
        return result.exit_code
    try:
        recording = report.read_recording(result.bag_dir)
        values = report.score(
            recording,
            nominal_period_s=1.0 / params["pid_controller"]["control_rate_hz"],
            window_s=duration_s if sim_time else None,
        )
    except ValueError as exc:
        launcher.say(f"cannot score the recording: {exc}")
        return result.exit_code or 1
    recorded_s = result.control_seconds if result.interrupted or not sim_time else duration_s
    if sim_time and result.failure is not None and values.get("recorded_duration_s") is not None:
        recorded_s = min(recorded_s, values["recorded_duration_s"])  # ended early: the ticks' own span (seeded)
    values.update(
        {
            "duration_s": round(recorded_s, 3),
            "interrupted": result.interrupted,
            "preset": preset,
            "robot": robot,
            "seed": seed,
            "mode": "single_process" if single_process else "multi_process",
            "clock": "sim_lockstep" if sim_time else "wall",
        }
    )
    if nodes is not None and len(result.local_nodes) < 5:  # a split run: what ran here (the rest elsewhere)
        values["nodes_here"] = ",".join(result.local_nodes)
    # Wall-clock figures of a lockstep run differ run to run: keep them out of metrics.json.
    wall = {"real_time_factor": result.real_time_factor, "wall_duration_s": result.wall_seconds}
    # How many messages the bag misses depends on when the nodes stopped, not on the seed.
    (wall if sim_time else values)["unrecorded_messages"] = sum(result.unrecorded.values())
    if sim_time:
        wall.update(result.usage)
    else:
        values["realtime_requested"] = realtime
        values.update(result.usage)
    report.write_metrics(out / "metrics.json", values)
    if sim_time:
        report.write_metrics(out / "timing.json", wall)
    plots.plot_tracking(recording, out / "tracking.png", title=f"{robot}, preset {preset}, seed {seed}")
    print_table(values | (wall if sim_time else {}), title=f"run: {robot}, preset {preset}, seed {seed} → {out}")
    return result.exit_code


def score(run_dir: Path, *, as_json: bool = False) -> int:
    from robot_controller.scoring import report

    try:
        recording = report.read_recording(run_dir / "bag")
        values = report.score(recording, window_s=_scored_window_s(run_dir))
    except (FileNotFoundError, ValueError) as exc:
        print(f"robot-controller: cannot score {run_dir}: {exc}", file=sys.stderr)
        return 2
    if as_json:
        print(json.dumps(values, indent=2, sort_keys=True))
    else:
        print_table(values, title=f"re-scored {run_dir / 'bag'}")
    return 0


def _scored_window_s(run_dir: Path) -> float | None:
    """A lockstep run was scored over its ``--duration`` from its first tick (the simulator
    runs on a little past it): the same window, from the run's ``metrics.json``, if there is one."""
    try:
        saved = json.loads((run_dir / "metrics.json").read_text())
        if saved["clock"] == "sim_lockstep" and saved["duration_s"] > 0:
            return float(saved["duration_s"])
    except (OSError, ValueError, TypeError, KeyError):
        pass  # none, or not one of ours: the whole recording
    return None


def list_params(*, preset: str, config: list[Path] | None, as_yaml: bool, robot: str = "one_dof") -> int:
    values = cfg.load_stack(preset, config, robot)
    if as_yaml:
        print(cfg.params_yaml(values), end="")
        return 0
    from robot_controller.parameters.law_params import node_specs

    for node in cfg.NODES:
        print(f"{node}:")
        for spec in node_specs(node, values[node]):
            print(
                f"  {spec.name} = {values[node][spec.name]!r}: {spec.describe()}"
                + (" (read-only)" if spec.read_only else "")
            )
    return 0


def print_table(values: dict, title: str, headline: tuple[str, ...] = HEADLINE) -> None:
    from rich.console import Console
    from rich.table import Table

    from robot_controller.scoring.report import joint_table

    table = Table(title=title)
    table.add_column("metric")
    table.add_column("value", justify="right")
    for key in headline + tuple(sorted(k for k in values if k not in headline)):
        if key in values and not isinstance(values[key], list):  # the per-joint lists: in their own table
            value = values[key]
            table.add_row(key, f"{value:.6g}" if isinstance(value, float) else str(value))
    Console().print(table)
    joints = joint_table(values)
    if joints is not None:
        Console().print(joints)


def view(run_dir: Path, *, port: int, serve: bool) -> int:
    from robot_controller.view.from_bag import build_view_from_bag

    if not (run_dir / "bag").is_dir():
        raise UsageError(f"{run_dir}: no bag/ here (not a run directory)")
    build_view_from_bag(run_dir, port, serve)
    return 0
