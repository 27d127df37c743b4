"""``robot-controller``'s experiment verbs: step, compare, exercise, tune,
identify, bench, faults and network, each writing its results to a directory."""

from __future__ import annotations

from pathlib import Path

from robot_controller import verbs_experiments
from robot_controller.cli_options import (
    compare_entries,
    controller_option,
    positive_int,
    positive_seconds,
    robot_option,
    stack_options,
    step_size_rad,
    verb,
)
from robot_controller.verbs import output_dir


def experiment_verbs(sub) -> None:
    p = verb(
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
    p.add_argument("--amplitude", type=step_size_rad, default=0.5, help="step size, rad (default 0.5)")
    p.add_argument(
        "--shaping",
        default="min_time",
        choices=("min_time", "none"),
        help="shape the step into the fastest move within the acceleration limit (default), or jump",
    )
    p.add_argument("--out", type=Path)
    stack_options(p)
    controller_option(p)
    p.add_argument("--sim-time", action="store_true", help="deterministic lockstep")
    p = verb(
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
    robot_option(p)
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
    p.add_argument("--amplitude", type=step_size_rad, default=0.5, help="step size, rad")
    p = verb(
        sub,
        "exercise",
        "one of the tutorial's exercises as a reproducible experiment",
        lambda a: verbs_experiments.exercise(
            a.name, output_dir(a.out, Path("runs") / f"exercise-{a.name}"), quick=a.quick, controller=a.controller
        ),
    )
    p.add_argument("name", choices=verbs_experiments.EXERCISE_NAMES)
    controller_option(p)  # exercise disturbance: the law runs beside the others
    p.add_argument("--out", type=Path, help="output directory (default runs/exercise-NAME)")
    p.add_argument("--quick", action="store_true", help="a short form (the test suite's)")
    p = verb(
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
    stack_options(p, seed=False)
    controller_option(p)  # a law of one's own: its gain=True parameters, searched on the in-process loop
    p.add_argument("--quick", action="store_true", help="a short search and short checks")
    p = verb(
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
    stack_options(p)
    p.add_argument("--duration", type=positive_seconds, default=20.0, help="excitation, sim s (default 20)")
    p = verb(
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
    p = verb(
        sub,
        "faults",
        "freeze each node mid-motion (SIGSTOP) and measure what the arm did",
        lambda a: verbs_experiments.faults(
            output_dir(a.out, Path("runs/faults")), quick=a.quick, robot=a.robot, controller=a.controller
        ),
    )
    robot_option(p)
    controller_option(p)
    p.add_argument("--out", type=Path, help="output directory (default runs/faults)")
    p.add_argument("--quick", action="store_true", help="two cases: sensor and controller frozen 0.5 s")
    p = verb(
        sub,
        "network",
        "the loop split over two network namespaces: loss, a bandwidth cap, a cut link (needs root)",
        lambda a: _network(a.out, a.quick),
    )
    p.add_argument("--out", type=Path, help="output directory (default runs/network)")
    p.add_argument("--quick", action="store_true", help="a short subset (the test suite's)")


def _network(out: Path | None, quick: bool) -> int:
    from robot_controller_lab.network import bench

    return bench.main(output_dir(out, Path("runs/network")), quick=quick)
