"""``robot-controller``: run the loop, score a recording, list parameters.

Each verb is a plain function returning an exit code; ``main`` only parses.
"""
from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import signal
import sys
from pathlib import Path

from robot_controller import parameters as cfg
from robot_controller.parameters import consistency as config_check
from robot_controller.core.errors import ConfigError

class UsageError(Exception):
    """A mistake of the user's: one line on stderr, exit code 2."""


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


HEADLINE = ("tracking_rms_rad", "tracking_max_rad", "measured_rms_rad", "control_rate_hz", "jitter_p99_ms",
            "missed_cycles", "latency_p50_ms", "latency_p99_ms", "peak_torque_nm", "duration_s", "real_time_factor")


def run(*, duration_s: float, out: Path | None, preset: str, seed: int, config: list[Path] | None,
        single_process: bool, realtime: bool = False, sim_time: bool = False, respawn: bool = False) -> int:
    from robot_controller.runner import launcher
    from robot_controller.scoring import report

    params = cfg.load_stack(preset, config)
    params["sensor_node"]["seed"] = seed
    config_check.check_stack(params)  # before the output folder is made
    out = output_dir(out, Path("runs") / dt.datetime.now().strftime("%Y%m%d-%H%M%S"))
    result = launcher.launch(params, out_dir=out, duration_s=duration_s, single_process=single_process,
                             realtime=realtime, sim_time=sim_time, respawn=respawn)
    if result.interrupted:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # scoring takes a second: let it finish
    if result.exit_code != 0 and not any(result.message_counts.values()):
        return result.exit_code
    try:
        recording = report.read_recording(result.bag_dir)
        values = report.score(recording, nominal_period_s=1.0 / params["pid_controller"]["control_rate_hz"],
                              window_s=duration_s if sim_time else None)
    except ValueError as exc:
        launcher.say(f"cannot score the recording: {exc}")
        return result.exit_code or 1
    recorded_s = result.control_seconds if result.interrupted or not sim_time else duration_s
    values.update({"duration_s": round(recorded_s, 3), "interrupted": result.interrupted, "preset": preset,
                   "seed": seed, "mode": "single_process" if single_process else "multi_process",
                   "clock": "sim_lockstep" if sim_time else "wall"})
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
    report.plot_tracking(recording, out / "tracking.png", title=f"preset {preset}, seed {seed}")
    print_table(values | (wall if sim_time else {}), title=f"run: preset {preset}, seed {seed} → {out}")
    return result.exit_code


def score(run_dir: Path, *, as_json: bool = False) -> int:
    from robot_controller.scoring import report

    try:
        recording = report.read_recording(run_dir / "bag")
        values = report.score(recording)
    except (FileNotFoundError, ValueError) as exc:
        print(f"robot-controller: cannot score {run_dir}: {exc}", file=sys.stderr)
        return 2
    if as_json:
        print(json.dumps(values, indent=2, sort_keys=True))
    else:
        print_table(values, title=f"re-scored {run_dir / 'bag'}")
    return 0


def bench(out: Path, *, quick: bool, soak_s: float | None = None) -> int:
    from robot_controller.experiments import bench as bench_module

    bench_module.bench(out, quick=quick, soak_s=soak_s, progress=lambda text: print(f"[bench] {text}", flush=True))
    print((out / "bench.md").read_text())
    return 0


def step(*, amplitude: float, shaping: str, out: Path | None, preset: str, seed: int, config: list[Path] | None,
         sim_time: bool) -> int:
    from robot_controller.experiments import step_compare as experiments

    params = cfg.load_stack(preset, config)
    config_check.check_stack(experiments.step_params(params, amplitude, shaping))
    out = output_dir(out, Path("runs") / ("step-" + dt.datetime.now().strftime("%Y%m%d-%H%M%S")))
    try:
        values = experiments.step(params, out, amplitude=amplitude, shaping=shaping, sim_time=sim_time, seed=seed)
    except ConfigError:
        raise  # a user error: one line, exit 2
    except (RuntimeError, ValueError) as exc:
        print(f"robot-controller: {exc}", file=sys.stderr)
        return 1
    print_table(values, title=f"step {amplitude} rad ({shaping}) → {out}", headline=STEP_HEADLINE)
    return 0


def compare(*, out: Path, seeds: int, duration_s: float, amplitude: float) -> int:
    from robot_controller.experiments import step_compare as experiments

    try:
        experiments.compare(out, seeds=seeds, sine_duration_s=duration_s, amplitude=amplitude,
                            progress=lambda text: print(f"[compare] {text}", flush=True))
    except (RuntimeError, ValueError, FileExistsError) as exc:
        print(f"robot-controller: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("robot-controller: compare interrupted", file=sys.stderr)
        return 130
    print((out / "compare.md").read_text())
    return 0


def faults(out: Path, *, quick: bool) -> int:
    from robot_controller.experiments import faults as faults_module

    try:
        faults_module.faults(out, quick=quick, progress=lambda text: print(f"[faults] {text}", flush=True))
    except (RuntimeError, ValueError, FileExistsError) as exc:
        print(f"robot-controller: {exc}", file=sys.stderr)
        return 1
    print((out / "faults.md").read_text())
    return 0


def estop(*, release: bool) -> int:
    from robot_controller.ros import estop as estop_module

    heard, report = estop_module.send(engage=not release)
    print(f"robot-controller: {report}", file=sys.stdout if heard else sys.stderr)
    return 0 if heard else 1


def list_params(*, preset: str, config: list[Path] | None, as_yaml: bool) -> int:
    values = cfg.load_stack(preset, config)
    if as_yaml:
        print(cfg.params_yaml(values), end="")
        return 0
    for node in cfg.NODES:
        print(f"{node}:")
        for spec in cfg.SCHEMA[node]:
            print(f"  {spec.name} = {values[node][spec.name]!r}: {spec.describe()}"
                  + (" (read-only)" if spec.read_only else ""))
    return 0


STEP_HEADLINE = ("overshoot_pct", "rise_time_s", "settling_time_s", "steady_state_error_rad", "peak_torque_nm")


def print_table(values: dict, title: str, headline: tuple[str, ...] = HEADLINE) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title=title)
    table.add_column("metric")
    table.add_column("value", justify="right")
    for key in headline + tuple(sorted(k for k in values if k not in headline)):
        if key in values:
            value = values[key]
            table.add_row(key, f"{value:.6g}" if isinstance(value, float) else str(value))
    Console().print(table)


def main(argv: list[str] | None = None) -> int:
    parser = Parser(prog="robot-controller", description=__doc__.splitlines()[0])
    verbs = parser.add_subparsers(dest="verb", required=True, parser_class=Parser)
    p_run = verbs.add_parser("run", help="run the five-node loop, record it and score it")
    p_run.add_argument("--duration", type=positive_seconds, default=20.0,
                       help="seconds of control to record (default 20)")
    p_run.add_argument("--out", type=Path, help="output directory (default runs/<timestamp>)")
    p_run.add_argument("--preset", default="default", choices=cfg.available_presets())
    p_run.add_argument("--seed", type=int, default=0, help="sensor noise seed (default 0)")
    p_run.add_argument("--config", type=Path, action="append",
                       help="ROS 2 parameter file layered over the preset (repeatable: later files over earlier)")
    p_run.add_argument("--single-process", action="store_true", help="all five nodes on one executor")
    p_run.add_argument("--sim-time", action="store_true",
                       help="deterministic lockstep on /clock, as fast as the graph goes (--duration in sim seconds)")
    p_run.add_argument("--respawn", action="store_true",
                       help="start a node that dies again (wall clock), as ros2 launch's respawn=True")
    p_run.add_argument("--realtime", action="store_true",
                       help="run the simulator's pacing thread SCHED_FIFO, with a CPU budget (see README)")
    p_score = verbs.add_parser("score", help="re-score a run directory from its bag")
    p_score.add_argument("run_dir", type=Path)
    p_score.add_argument("--json", action="store_true", help="print the metrics as JSON")
    p_step = verbs.add_parser("step", help="a step response: overshoot, rise, settling, steady-state error, torque")
    p_step.add_argument("--amplitude", type=float, default=0.5, help="step size, rad (default 0.5)")
    p_step.add_argument("--shaping", default="min_time", choices=("min_time", "none"),
                        help="shape the step into the fastest move within the acceleration limit (default), or jump")
    p_step.add_argument("--out", type=Path)
    p_step.add_argument("--preset", default="default", choices=cfg.available_presets())
    p_step.add_argument("--seed", type=int, default=0)
    p_step.add_argument("--config", type=Path, action="append", help="as run's")
    p_step.add_argument("--sim-time", action="store_true", help="deterministic lockstep")
    p_compare = verbs.add_parser("compare", help="the tutorial preset, PID, PID+FF, PID+FF+Kalman, LQR on sine and step")
    p_compare.add_argument("--out", type=Path, help="output directory (default runs/compare)")
    p_compare.add_argument("--seeds", type=int, default=5)
    p_compare.add_argument("--duration", type=positive_seconds, default=10.0, help="sine duration, sim s (default 10)")
    p_compare.add_argument("--amplitude", type=float, default=0.5, help="step size, rad")
    p_bench = verbs.add_parser("bench", help="timing benchmark: jitter, latency, lockstep speed, core speed")
    p_bench.add_argument("--out", type=Path, help="output directory (default runs/bench)")
    p_bench.add_argument("--quick", action="store_true", help="a few seconds per scenario")
    p_bench.add_argument("--soak-s", type=positive_seconds,
                         help="length of the soak run, wall s (default 600, 20 with --quick)")
    p_faults = verbs.add_parser("faults", help="freeze each node mid-motion (SIGSTOP) and measure what the arm did")
    p_faults.add_argument("--out", type=Path, help="output directory (default runs/faults)")
    p_faults.add_argument("--quick", action="store_true", help="two cases: sensor and controller frozen 0.5 s")
    p_estop = verbs.add_parser("estop", help="emergency stop of the running graph: torque off, brakes on, latched")
    p_estop.add_argument("--release", action="store_true", help="release the e-stop; the loop re-acquires")
    p_params = verbs.add_parser("params", help="list every node parameter with its default and meaning")
    p_params.add_argument("--yaml", action="store_true",
                          help="print the values as a ROS 2 parameter file (for --config or --params-file)")
    p_params.add_argument("--preset", default="default", choices=cfg.available_presets())
    p_params.add_argument("--config", type=Path, action="append", help="as run's")
    args = parser.parse_args(argv)
    try:
        return dispatch(args)
    except (UsageError, ConfigError) as exc:
        print(f"robot-controller {args.verb}: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # `robot-controller params | head`
        return 0
    except OSError as exc:  # a path of the user's: missing, a directory, not writable
        where = f" {exc.filename}" if exc.filename else ""
        print(f"robot-controller {args.verb}:{where}: {exc.strerror or exc}", file=sys.stderr)
        return 2


def dispatch(args: argparse.Namespace) -> int:
    if args.verb == "run":
        return run(duration_s=args.duration, out=args.out, preset=args.preset, seed=args.seed, config=args.config,
                   single_process=args.single_process, realtime=args.realtime,
                   sim_time=args.sim_time, respawn=args.respawn)
    if args.verb == "step":
        return step(amplitude=args.amplitude, shaping=args.shaping, out=args.out, preset=args.preset, seed=args.seed,
                    config=args.config, sim_time=args.sim_time)
    if args.verb == "compare":
        return compare(out=output_dir(args.out, Path("runs/compare")), seeds=args.seeds, duration_s=args.duration,
                       amplitude=args.amplitude)
    if args.verb == "bench":
        return bench(output_dir(args.out, Path("runs/bench")), quick=args.quick, soak_s=args.soak_s)
    if args.verb == "faults":
        return faults(output_dir(args.out, Path("runs/faults")), quick=args.quick)
    if args.verb == "estop":
        return estop(release=args.release)
    if args.verb == "score":
        return score(args.run_dir, as_json=args.json)
    return list_params(preset=args.preset, config=args.config, as_yaml=args.yaml)


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
