"""The experiment verbs of ``robot-controller``: step, compare, faults, the
tutorial's exercises, tune, identify and bench. Each runs its experiment
(``experiments``) with a progress line, prints the report it wrote and returns
an exit code; a user's mistake raises ``UsageError`` or ``ConfigError``.
"""

from __future__ import annotations

import datetime as dt
import sys
from pathlib import Path

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError
from robot_controller.parameters import consistency as config_check
from robot_controller.progress import StepProgress
from robot_controller.verbs import UsageError, output_dir, print_table

STEP_HEADLINE = ("overshoot_pct", "rise_time_s", "settling_time_s", "steady_state_error_rad", "peak_torque_nm")


def bench(out: Path, *, quick: bool, soak_s: float | None = None) -> int:
    from robot_controller_lab import bench as bench_module

    with StepProgress("bench", len(bench_module.SCENARIOS)) as progress:
        bench_module.bench(out, quick=quick, soak_s=soak_s, progress=progress)
    print((out / "bench.md").read_text())
    return 0


def step(
    *,
    amplitude: float,
    shaping: str,
    out: Path | None,
    preset: str,
    seed: int,
    config: list[Path] | None,
    sim_time: bool,
    robot: str = "one_dof",
    controller: str | None = None,
) -> int:
    from robot_controller.experiments import step as experiments
    from robot_controller.experiments.laws import with_controller

    params = with_controller(cfg.load_stack(preset, config, robot), controller)
    config_check.check_stack(experiments.step_params(params, amplitude, shaping))
    out = output_dir(out, Path("runs") / ("step-" + dt.datetime.now().strftime("%Y%m%d-%H%M%S")))
    try:
        values = experiments.step_response(
            params, out, amplitude=amplitude, shaping=shaping, sim_time=sim_time, seed=seed
        )
    except ConfigError:
        raise  # a user error: one line, exit 2
    except (RuntimeError, ValueError) as exc:
        print(f"robot-controller: {exc}", file=sys.stderr)
        return 1
    print_table(values, title=f"step {amplitude} rad ({shaping}) → {out}", headline=STEP_HEADLINE)
    return 0


def compare(
    *,
    out: Path,
    seeds: int,
    duration_s: float,
    amplitude: float,
    robot: str = "one_dof",
    controllers: list[str] | None = None,
    in_process: bool = False,
) -> int:
    from robot_controller.experiments import compare as experiments

    try:
        with StepProgress("compare", len(experiments.contenders(controllers)) * seeds) as progress:
            experiments.compare(
                out,
                seeds=seeds,
                sine_duration_s=duration_s,
                amplitude=amplitude,
                progress=progress,
                robot=robot,
                controllers=controllers,
                in_process=in_process,
            )
    except (RuntimeError, ValueError, FileExistsError) as exc:
        print(f"robot-controller: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("robot-controller: compare interrupted", file=sys.stderr)
        return 130
    print((out / "compare.md").read_text())
    return 0


def faults(out: Path, *, quick: bool, robot: str = "one_dof", controller: str | None = None) -> int:
    from robot_controller.experiments import faults as faults_module

    try:
        with StepProgress("faults", len(faults_module.cases(quick))) as progress:
            faults_module.faults(out, quick=quick, progress=progress, robot=robot, controller=controller)
    except (RuntimeError, ValueError, FileExistsError) as exc:
        print(f"robot-controller: {exc}", file=sys.stderr)
        return 1
    print((out / "faults.md").read_text())
    return 0


# The exercises by name, for the parser (importing them would slow every verb's start).
EXERCISE_NAMES = ("tune", "disturbance", "windup", "lqr")


#: The exercises that take ``--controller`` (the law runs beside their own contenders).
EXERCISES_WITH_CONTROLLER = ("disturbance",)


def exercise(name: str, out: Path, *, quick: bool, controller: str | None = None) -> int:
    from robot_controller.experiments.exercises import EXERCISES, disturbance

    if controller is not None and name not in EXERCISES_WITH_CONTROLLER:
        raise UsageError(f"--controller: exercise {name} compares its own controllers; it applies to disturbance")
    chosen = EXERCISES[name]
    extra = {} if controller is None else {"controller": controller}
    # A law of one's own is one more contender of the disturbance exercise (the only one that takes it).
    extra_steps = disturbance.RUNS_PER_CONTENDER if controller is not None else 0
    with StepProgress(f"exercise {name}", chosen.steps(quick) + extra_steps) as progress:
        chosen.run(out, quick=quick, progress=progress, **extra)
    print((out / "report.md").read_text())
    return 0


def tune(
    out: Path,
    *,
    preset: str,
    config: list[Path] | None,
    quick: bool,
    robot: str = "one_dof",
    controller: str | None = None,
) -> int:
    from robot_controller.experiments import autotune as tune_module
    from robot_controller.experiments import laws

    params = laws.with_controller(cfg.load_stack(preset, config, robot), controller)
    config_check.check_stack(params)
    if laws.is_plugin(params["pid_controller"]["controller_type"]):  # a law of one's own: on the in-process loop
        from robot_controller.experiments.autotune import law as law_tune

        try:
            with StepProgress("tune", law_tune.steps(quick)) as progress:
                law_tune.tune_law(params, out, quick=quick, progress=progress)
        except RuntimeError as exc:  # nothing in the search met the margins
            print(f"robot-controller: {exc}", file=sys.stderr)
            return 1
        print((out / "report.md").read_text())
        print(f"robot-controller: use it with --config {out / 'tuned.yaml'}")
        return 0
    if params["trajectory_planner"]["joint_count"] > 1:
        raise UsageError(
            f"--robot {robot}: tune designs one joint's gains; on a chain of joints the LQR's weights serve "
            "every joint, each scaled by its own inertia (lqr_q, lqr_r, reference_inertia)"
        )
    with StepProgress("tune", tune_module.steps(quick)) as progress:
        tune_module.tune(params, out, quick=quick, progress=progress)
    print((out / "report.md").read_text())
    print(f"robot-controller: use it with --config {out / 'tuned.yaml'}")
    return 0


def identify(
    out: Path, *, preset: str, config: list[Path] | None, seed: int, duration_s: float, robot: str = "one_dof"
) -> int:
    from robot_controller.experiments import identify as identify_module

    params = cfg.load_stack(preset, config, robot)
    config_check.check_stack(params)
    with StepProgress("identify", 4) as progress:
        identify_module.identify(params, out, duration_s=duration_s, seed=seed, progress=progress)
    print((out / "identification.md").read_text())
    print(f"robot-controller: use it with --config {out / 'identified.yaml'} (after your other --config files)")
    return 0
