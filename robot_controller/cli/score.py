"""A saved run directory: ``score`` re-scores its bag, ``view`` serves its 3D view and plots."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from robot_controller.cli.args import UsageError, port, verb
from robot_controller.cli.output import print_summary, print_table


def register(sub) -> None:
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

    if not (run_dir / "bag").is_dir():
        raise UsageError(f"{run_dir}: no bag/ here (not a run directory)")
    build_view_from_bag(run_dir, port, serve)
    return 0
