"""``robot-controller campaign``: a robustness campaign over worlds the controller does not know (local worker
processes or a Ray cluster), resumable, with its report; ``campaign replay DIR RUN_ID`` runs one of its runs again
through the ROS graph on sim time."""

from __future__ import annotations

import argparse
from pathlib import Path

from robot_controller.cli.args import UsageError, positive_float, positive_int, verb

USAGE = (
    "campaign SPEC.yaml --out DIR [--workers N | --ray ADDRESS] [--controllers A,B] [--run-timeout S]; "
    "campaign replay DIR RUN_ID"
)


def register(sub) -> None:
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
    for flag, given in (("--controller", a.controller),):
        if given is not None:
            raise UsageError(f"{flag} is replay's; to compare controllers use --controllers A,B")
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
    from robot_controller.experiments.campaign import draws, replay
    from robot_controller.runner.options import RunOptions

    folder = Path(a.target[1])
    spec, row, controller_type = replay.replay_row(folder, run_id, a.controller)
    out = output_dir(a.out, a.out)
    layer_file = cfg.write_params_file(replay.replay_layer(spec, run_id, controller_type), out / "replay.yaml")
    configs = ((spec.config,) if spec.config else ()) + (layer_file,)
    options = RunOptions(
        duration_s=spec.duration_s,
        robot=spec.robot,
        config=configs,
        seed=draws.run_seed(spec.seed, run_id),
        sim_time=True,
    )
    code = run(options, out)
    metrics_path = out / "metrics.json"
    if not metrics_path.is_file():
        return code or 1
    import json

    print(f"run {run_id} of {folder}: the campaign's (in process) beside the graph's (sim time)")
    for name, ours, theirs, diff in replay.compared(row, json.loads(metrics_path.read_text())):
        print(f"  {name:<18} {ours:10.5g} {theirs:10.5g}  {diff:+.1%}")
    return code
