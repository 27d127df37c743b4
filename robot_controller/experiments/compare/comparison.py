"""The controller comparison (``robot-controller compare``): each contender on the sine and on a step,
over several seeds, on sim time side by side, or on the in-process loop."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from robot_controller.experiments.compare.contenders import contenders
from robot_controller.experiments.compare.pairs import run_pair, run_pair_in_process
from robot_controller.experiments.compare.report import plot_compare, render_compare
from robot_controller.experiments.compare.workers import run_side_by_side
from robot_controller.scoring import report

#: (contender, seed) pairs run side by side by ``compare``: three keep two cores busy.
COMPARE_WORKERS = 3


def compare(
    out: Path,
    *,
    seeds: int,
    sine_duration_s: float,
    amplitude: float,
    progress=print,
    workers: int = COMPARE_WORKERS,
    robot: str = "one_dof",
    controllers: Sequence[str] | None = None,
    in_process: bool = False,
) -> dict[str, dict[str, dict[str, float]]]:
    """Every contender (``controllers``: :func:`contenders`) on the sine and on the step, ``seeds`` seeds each,
    on sim time (``workers`` pairs at once, each on a ROS domain of its own) or ``in_process``: the same table.

    :raises RuntimeError: a failed run, naming its directory, once the pairs under way have ended
    """
    chosen = contenders(controllers)
    out.mkdir(parents=True, exist_ok=True)
    pairs = [(replace(contender, robot=robot), seed) for contender in chosen for seed in range(seeds)]
    if in_process or workers <= 1:
        figures = {}
        for contender, seed in pairs:
            progress(f"{contender.name}: seed {seed}")
            if in_process:
                figures[contender.name, seed] = run_pair_in_process(contender, seed, sine_duration_s, amplitude)
            else:
                figures[contender.name, seed] = run_pair(contender, seed, out, sine_duration_s, amplitude)
    else:
        figures = run_side_by_side(pairs, out, sine_duration_s, amplitude, progress, workers)
    table: dict[str, dict[str, dict[str, float]]] = {}
    for contender in chosen:
        rows: dict[str, list[float]] = {}
        for seed in range(seeds):
            for key, value in figures[contender.name, seed].items():
                rows.setdefault(key, []).append(value)
        table[contender.name] = {
            key: {"mean": float(np.mean(v)), "std": float(np.std(v)), "min": float(np.min(v)), "max": float(np.max(v))}
            for key, v in rows.items()
        }
    report.write_metrics(out / "compare.json", table)
    text = render_compare(table, seeds, sine_duration_s, amplitude, robot, chosen, in_process=in_process)
    (out / "compare.md").write_text(text)
    plot_compare(table, out / "compare.png")
    return table
