"""``robot-controller``: run the loop, score a recording, list parameters.

Each verb is a plain function in ``verbs`` returning an exit code; ``main``
only parses, dispatches, and turns a user's mistake into one line, exit 2.
"""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError
from robot_controller.verbs import (UsageError, bench, compare, estop, faults, list_params, output_dir, run, score,
                                    step)

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
