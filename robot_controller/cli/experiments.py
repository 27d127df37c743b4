"""The verbs that run an experiment and report on it: ``step``, ``compare``, ``exercise``, ``tune``, ``identify``,
``faults``, and ``campaign`` (a robustness campaign over worlds the controller does not know, on local worker
processes or a Ray cluster, resumable; ``campaign replay DIR RUN_ID`` runs one of its runs again through the ROS
graph on sim time)."""

from __future__ import annotations

import argparse
import datetime as dt
import json
import sys
from pathlib import Path

from robot_controller.cli.args import (
    UsageError,
    compare_entries,
    controller_option,
    out_option,
    positive_float,
    positive_int,
    positive_seconds,
    robot_option,
    stack_options,
    step_size_rad,
    verb,
)
from robot_controller.cli.output import output_dir, print_summary, run_experiment, say_arm
from robot_controller.core.errors import ConfigError
from robot_controller.runner.options import RunOptions

# The exercises by name, for the parser (importing them would slow every verb's start).
EXERCISE_NAMES = ("tune", "disturbance", "windup", "lqr")
#: The exercises that take ``--controller`` (the law runs beside their own contenders).
EXERCISES_WITH_CONTROLLER = ("disturbance",)


def register(sub) -> None:
    p = verb(sub, "step", "a step response: overshoot, rise, settling, steady-state error, torque", step)
    p.add_argument("--amplitude", type=step_size_rad, default=0.5, help="step size, rad (default 0.5)")
    p.add_argument(
        "--shaping",
        default="min_time",
        choices=("min_time", "none"),
        help="shape the step into the fastest move within the acceleration limit (default), or jump",
    )
    out_option(p, None)
    stack_options(p)
    controller_option(p)
    p.add_argument("--sim-time", action="store_true", help="deterministic: on sim time, as fast as the graph goes")

    p = verb(sub, "compare", "the tutorial preset, PID, PID+FF, PID+FF+Kalman, LQR on sine and step", compare)
    robot_option(p)
    p.add_argument(
        "--controllers",
        type=compare_entries,
        metavar="A,B,...",
        help="the entries compared: configurations (default, tutorial, pid, pid_ff, pid_ff_kf, lqr) or laws "
        "(module:Class, path/to/file.py:Class, an installed law) with the default stack (default: the configurations)",
    )
    in_process_help = "on the in-process loop (no ROS): the graph's figures, in seconds"
    p.add_argument("--in-process", action="store_true", help=in_process_help)
    out_option(p, "runs/compare")
    p.add_argument("--seeds", type=positive_int, default=5)
    p.add_argument("--duration", type=positive_seconds, default=10.0, help="sine duration, sim s (default 10)")
    p.add_argument("--amplitude", type=step_size_rad, default=0.5, help="step size, rad")

    p = verb(sub, "exercise", "one of the tutorial's exercises as a reproducible experiment", exercise)
    p.add_argument("name", choices=EXERCISE_NAMES)
    controller_option(p)  # exercise disturbance: the law runs beside the others
    out_option(p, "runs/exercise-NAME")
    p.add_argument("--quick", action="store_true", help="a short form (the test suite's)")

    p = verb(sub, "tune", "automatic gain design with robustness margins; writes tuned.yaml", tune)
    out_option(p, "runs/tune")
    stack_options(p, seed=False)
    controller_option(p)  # a law of one's own: its gain=True parameters, searched on the in-process loop
    p.add_argument("--quick", action="store_true", help="a short search and short checks")
    p.add_argument(
        "--target",
        choices=("tracking", "robust", "effort"),
        default="tracking",
        help="on a chain of joints, what each joint's design is for: tracking (the fastest feedback with 2 control "
        "periods of delay margin), robust (4 periods), effort (half that bandwidth, less torque and noise)",
    )

    identify_help = (
        "identify the arm's inertia, damping and friction (one joint: and gravity; a chain: and a payload on the "
        "last link); writes identified.yaml"
    )
    p = verb(sub, "identify", identify_help, identify)
    out_option(p, "runs/identify")
    stack_options(p)
    p.add_argument("--duration", type=positive_seconds, default=20.0, help="excitation, sim s (default 20)")

    p = verb(sub, "faults", "freeze each node mid-motion (SIGSTOP) and measure what the arm did", faults)
    robot_option(p)
    controller_option(p)
    out_option(p, "runs/faults")
    p.add_argument("--quick", action="store_true", help="two cases: sensor and controller frozen 0.5 s")
    wall_help = "freeze on the hardware-strict wall clock (as run --wall-clock), not in the default run's paced world"
    p.add_argument("--wall-clock", action="store_true", help=wall_help)


def step(a: argparse.Namespace) -> int:
    from robot_controller.experiments import step as experiments
    from robot_controller.experiments.laws import with_controller

    options = RunOptions.from_args(a)
    params = with_controller(options.params(), a.controller)
    shape = {"amplitude": a.amplitude, "shaping": a.shaping}
    checked = experiments.check_step(params, **shape, sim_time=options.sim_time, seed=options.seed)  # before the folder
    say_arm(options.robot)
    out = output_dir(a.out, Path("runs") / ("step-" + dt.datetime.now().strftime("%Y%m%d-%H%M%S")))
    try:
        values = experiments.step_response(checked, out, **shape)
    except ConfigError:
        raise  # a user error: one line, exit 2
    except (RuntimeError, ValueError) as exc:
        print(f"robot-controller step: FAILED: {exc}", file=sys.stderr)
        return 1
    from robot_controller.scoring import scored_run, summary

    limits = scored_run.effort_limits(checked.params, len(values["joint_names"]))
    rows = summary.step_rows(values, robot=options.robot, effort_limits=limits)
    rows += [("files", f"{out}/: step.png, metrics.json (every figure), bag/")]
    print_summary(summary.verdict(None), rows)
    return 0


def compare(a: argparse.Namespace) -> int:
    from robot_controller.experiments import compare as experiments

    say_arm(a.robot)
    out = output_dir(a.out, Path("runs/compare"))
    steps = len(experiments.contenders(a.controllers)) * a.seeds
    chosen = dict(seeds=a.seeds, sine_duration_s=a.duration, amplitude=a.amplitude, robot=a.robot)
    chosen.update(controllers=a.controllers, in_process=a.in_process)
    code = run_experiment(
        "compare", steps, lambda progress: experiments.compare(out, progress=progress, **chosen), out / "compare.md"
    )
    if code == 0:  # the reference arm's targets a contender missed, marked
        from robot_controller.scoring import summary

        for line in summary.compare_missed(json.loads((out / "compare.json").read_text()), a.robot):
            print(line)
    return code


def exercise(a: argparse.Namespace) -> int:
    from robot_controller.experiments.exercises import EXERCISES, disturbance

    if a.controller is not None and a.name not in EXERCISES_WITH_CONTROLLER:
        raise UsageError(f"--controller: exercise {a.name} compares its own controllers; it applies to disturbance")
    out = output_dir(a.out, Path("runs") / f"exercise-{a.name}")
    chosen = EXERCISES[a.name]
    extra = {} if a.controller is None else {"controller": a.controller}
    # A law of one's own is one more contender of the disturbance exercise.
    steps = chosen.steps(a.quick) + (disturbance.RUNS_PER_CONTENDER if a.controller is not None else 0)
    return run_experiment(
        f"exercise {a.name}", steps, lambda p: chosen.run(out, quick=a.quick, progress=p, **extra), out / "report.md"
    )


def tune(a: argparse.Namespace) -> int:
    from robot_controller.core.laws import registry
    from robot_controller.experiments import autotune, laws
    from robot_controller.parameters import consistency

    params = laws.with_controller(RunOptions.from_args(a).params(), a.controller)
    consistency.check_stack(params)
    controller_type = params["pid_controller"]["controller_type"]
    joint_count = params["trajectory_planner"]["joint_count"]
    per_joint = joint_count > 1 and registry.is_builtin(controller_type.strip())
    if not per_joint and a.target != "tracking":
        raise UsageError(
            f"--target {a.target}: only a chain's built-in law is designed per joint for a target; here tune searches "
            "for the best tracking within the margins"
        )
    say_arm(a.robot)
    out = output_dir(a.out, Path("runs/tune"))
    steps = autotune.steps(a.quick, controller_type, joint_count if per_joint else 1)

    def hint() -> str:
        if (out / "tuned.yaml").exists():
            return f"use it with --config {out / 'tuned.yaml'}"
        return "nothing better than the gains in force was found: nothing written to use"

    def design(progress) -> dict:
        return autotune.tune(params, out, quick=a.quick, progress=progress, target=a.target)

    return run_experiment("tune", steps, design, out / "report.md", hint)


def identify(a: argparse.Namespace) -> int:
    from robot_controller.experiments import identify as experiments
    from robot_controller.parameters import consistency

    options = RunOptions.from_args(a)
    params = options.params()
    consistency.check_stack(params)
    say_arm(options.robot)
    out = output_dir(a.out, Path("runs/identify"))
    hint = f"use it with --config {out / 'identified.yaml'} (after your other --config files)"

    def fit(progress) -> dict:
        return experiments.identify(params, out, duration_s=a.duration, seed=options.seed, progress=progress)

    return run_experiment("identify", experiments.steps(params), fit, out / "identification.md", hint)


def faults(a: argparse.Namespace) -> int:
    from robot_controller.experiments import faults as experiments

    say_arm(a.robot)
    out = output_dir(a.out, Path("runs/faults"))
    chosen = dict(quick=a.quick, robot=a.robot, controller=a.controller, wall_clock=a.wall_clock)
    entries: list[dict] = []

    def body(progress) -> None:
        entries.extend(experiments.faults(out, progress=progress, **chosen))

    def show() -> None:  # the short form: every case is in faults.md
        from robot_controller.scoring import summary

        failed = experiments.failed(entries)
        verdict = summary.verdict(f"{len(failed)} of {len(entries)} cases missed their goal" if failed else None)
        rows = summary.faults_rows(entries, failed, experiments.GOAL_DEVIATION_RAD)
        print_summary(verdict, [*rows, ("files", f"{out}/: faults.md (every case), faults.json, a folder per case")])

    code = run_experiment("faults", len(experiments.cases(a.quick)), body, out / "faults.md", show=show)
    for line in experiments.failed(entries):  # a joint out of its band by more than the goal, or a failed run
        print(f"robot-controller faults: FAILED: {line}", file=sys.stderr)
    return code or (1 if experiments.failed(entries) else 0)


USAGE = (
    "campaign SPEC.yaml --out DIR [--workers N | --ray ADDRESS] [--controllers A,B] [--run-timeout S]; "
    "campaign replay DIR RUN_ID"
)


def register_campaign(sub) -> None:
    p = verb(
        sub, "campaign", "a robustness campaign: many runs over varied worlds, resumable, with a report", _campaign
    )
    p.usage = (
        "robot-controller campaign SPEC.yaml --out DIR [--workers N | --ray ADDRESS] [--controllers A,B] "
        "[--run-timeout S]\n"
        "       robot-controller campaign replay DIR RUN_ID --out OUT [--controller NAME]"
    )
    p.add_argument(
        "target", nargs="+", metavar="ARG", help="the campaign's spec (docs/campaign.md), or: replay DIR RUN_ID"
    )
    p.add_argument(
        "--out", type=Path, help="the campaign's folder (the same again resumes it); replay: the run's folder"
    )
    p.add_argument("--workers", type=positive_int, help="local worker processes (default: every core)")
    p.add_argument(
        "--ray", metavar="ADDRESS", help="run on the Ray cluster at ADDRESS (auto: RAY_ADDRESS, or this host's)"
    )
    p.add_argument(
        "--controllers",
        metavar="A,B",
        help="compare these controllers on the same draws (laws: lqr, pid, path.py:Class)",
    )
    p.add_argument(
        "--run-timeout",
        type=positive_float,
        metavar="S",
        help="a run's wall-time limit, s: past it its process is killed, the run recorded as timed out and tried "
        "once more (default: the spec's run_timeout_s, else 60 s + 10 s per simulated second)",
    )
    p.add_argument("--controller", metavar="NAME", help="replay: the compared controller whose run to replay")


def _campaign(a: argparse.Namespace) -> int:
    if a.target[0] == "replay":
        if a.run_timeout is not None:
            raise UsageError("--run-timeout is the campaign's; replay runs through the ROS graph with its own limits")
        return _replay(a)
    if len(a.target) != 1:
        raise UsageError(f"expected one spec file, got {' '.join(a.target)} (usage: {USAGE})")
    if a.controller is not None:
        raise UsageError("--controller is replay's; to compare controllers use --controllers A,B")
    if a.out is None:
        raise UsageError("--out DIR is needed: the campaign's folder (the same again resumes it)")
    if a.ray is not None and a.workers is not None:
        raise UsageError("--workers is the local pool's; on Ray the cluster's CPUs run the tasks")
    names = None
    if a.controllers is not None:
        names = [n.strip() for n in a.controllers.split(",")]
        if len(names) < 2 or not all(names):
            raise UsageError(f"--controllers: expected two or more names separated by commas, got {a.controllers!r}")
    from robot_controller.experiments.campaign import campaign, report
    from robot_controller.experiments.campaign.spec import load_spec

    spec = load_spec(a.target[0])  # refused whole, before any folder or run
    if a.out.exists() and not a.out.is_dir():
        raise UsageError(f"--out {a.out}: exists and is not a directory")
    a.out.mkdir(parents=True, exist_ok=True)
    where = f"Ray at {a.ray}" if a.ray else f"{a.workers or campaign.executors.default_workers()} local workers"
    opened = campaign.open_store(spec, a.out, names)  # another campaign's folder: refused before anything is said
    limit_s = a.run_timeout or spec.timeout_s
    print(
        f"robot-controller campaign: {spec.runs} runs of {spec.duration_s:g} s on {spec.robot}, {where}, "
        f"each within {limit_s:g} s of wall time",
        flush=True,
    )
    store = campaign.run_campaign(
        spec, a.out, controllers=names, workers=a.workers, ray_address=a.ray, run_timeout_s=a.run_timeout, store=opened
    )
    labels = [c.label for c in campaign.contenders(spec, names)]
    path = report.write_report(spec, store.rows, a.out, labels)
    _say_end(spec, store.rows, labels, path)
    return 0


def _say_end(spec, rows, labels, path: Path) -> None:
    from robot_controller.experiments.campaign import report

    target = report.headline(rows)
    for label in labels:
        mine = [r for r in rows if r["controller"] == label]
        ok = [r for r in mine if r.get("status") == "ok"]
        who = f"{label}: " if label else ""
        line = f"{who}{len(ok)} of {len(mine)} runs finished"
        timed_out = sum(r.get("status") == "timed_out" for r in mine)
        faulted = sum(bool(r.get("law_fault")) for r in ok)
        said = [f"{timed_out} timed out"] * bool(timed_out) + [f"{faulted} with a law fault"] * bool(faulted)
        if said:
            line += f" ({', '.join(said)})"
        retried = sum((r.get("attempts") or 1) > 1 for r in mine)
        if retried:
            line += f", {retried} tried twice"
        if ok:
            worst = max(ok, key=lambda r: r[target])
            line += f"; worst {target} {worst[target]:.4g} (run {worst['run_id']})"
        if spec.pass_bounds:
            passed = sum(report.passes(r, spec.pass_bounds) for r in mine)
            lo, hi = report.wilson_interval(passed, len(mine))
            line += f"; pass {passed}/{len(mine)} (95 % CI {lo:.0%}–{hi:.0%})"
        print(line)
    print(f"report: {path} (results.parquet, distributions.png, sensitivity.png beside it)")


def _replay(a: argparse.Namespace) -> int:
    if len(a.target) != 3:
        raise UsageError(f"replay: expected DIR RUN_ID (usage: {USAGE})")
    try:
        run_id = int(a.target[2])
    except ValueError:
        raise UsageError(f"replay: RUN_ID is a run's number, got {a.target[2]!r}") from None
    if a.out is None:
        raise UsageError("replay: --out OUT is needed: the replayed run's folder")
    from robot_controller import parameters as cfg
    from robot_controller.cli.output import output_dir
    from robot_controller.cli.run import run
    from robot_controller.experiments.campaign import campaign
    from robot_controller.experiments.campaign.spec import run_seed
    from robot_controller.runner.options import RunOptions

    folder = Path(a.target[1])
    spec, row, controller_type = campaign.replay_row(folder, run_id, a.controller)
    out = output_dir(a.out, a.out)
    layer_file = cfg.write_params_file(campaign.replay_layer(spec, run_id, controller_type), out / "replay.yaml")
    configs = ((spec.config,) if spec.config else ()) + (layer_file,)
    options = RunOptions(
        duration_s=spec.duration_s,
        robot=spec.robot,
        config=configs,
        seed=run_seed(spec.seed, run_id),
        sim_time=True,
    )
    code = run(options, out)
    metrics_path = out / "metrics.json"
    if not metrics_path.is_file():
        return code or 1
    import json

    print(f"run {run_id} of {folder}: the campaign's (in process) beside the graph's (sim time)")
    for name, ours, theirs, diff in campaign.compared(row, json.loads(metrics_path.read_text())):
        print(f"  {name:<18} {ours:10.5g} {theirs:10.5g}  {diff:+.1%}")
    return code
