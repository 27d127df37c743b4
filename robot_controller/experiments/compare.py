"""The controller comparison (``robot-controller compare``): each contender on
the sine and on a step, over several seeds, in lockstep, side by side; real
runs all (``step.run_and_score``), several at once on domains of their own;
or, with ``in_process``, the same runs on the in-process loop (no ROS).

The contenders are named configurations (:data:`CONTENDERS`, and ``default``:
the default preset as it is) or laws: an entry with a ':' (``module:Class``,
``file.py:Class``) or naming an installed law is that law with the default
stack (``--controllers default,tutorial,my_law.py:MyLaw``). A configuration's
name wins over an installed law's (``pid``, ``lqr``).

The parts: one pair's runs (``compare_pairs``), the pairs side by side in
worker processes (``compare_workers``), the table written (``compare_report``);
this module is the contenders and the comparison itself.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.experiments import laws
from robot_controller.experiments.compare_pairs import run_pair, run_pair_in_process
from robot_controller.experiments.compare_report import plot_compare, render_compare
from robot_controller.experiments.compare_workers import run_side_by_side
from robot_controller.scoring import report


@dataclass(frozen=True)
class Contender:
    name: str
    description: str
    preset: str
    overrides: dict[str, Any]
    robot: str = "one_dof"


CONTENDERS = (
    Contender("tutorial", "the tutorial's controller as written", "tutorial", {}),
    Contender(
        "pid",
        "PID, derivative on velocity error",
        "default",
        {"controller_type": "pid", "feedforward": "none", "estimator": "none"},
    ),
    Contender(
        "pid_ff",
        "PID + model feedforward",
        "default",
        {"controller_type": "pid", "feedforward": "full", "estimator": "none"},
    ),
    Contender(
        "pid_ff_kf",
        "PID + feedforward + Kalman filter",
        "default",
        {"controller_type": "pid", "feedforward": "full", "estimator": "kalman"},
    ),
    Contender(
        "lqr",
        "LQR + feedforward + Kalman filter (default)",
        "default",
        {"controller_type": "lqr", "feedforward": "full", "estimator": "kalman"},
    ),
)
#: Configurations by name for ``--controllers``: the contenders, and the default preset as it is.
NAMED = {c.name: c for c in CONTENDERS} | {"default": Contender("default", "the default preset", "default", {})}


def contenders(names: Sequence[str] | None = None) -> tuple[Contender, ...]:
    """The contenders ``names`` (``--controllers``) name, in order; every contender for None.
    ``ConfigError`` in one line for a name that is neither a configuration nor a law."""
    if names is None:
        return CONTENDERS
    chosen: list[Contender] = []
    for name in (n.strip() for n in names):
        if name in NAMED:
            contender = NAMED[name]
        elif laws.is_law(name):
            spec = laws.controller_type(name)
            contender = Contender(
                laws.label(name), f"{name} with the default stack", "default", {"controller_type": spec}
            )
        else:
            raise ConfigError(
                f"--controllers: {name!r} is neither a configuration ({', '.join(NAMED)}) nor a law "
                "(module:Class, path/to/file.py:Class or an installed law's name)"
            )
        taken = {c.name for c in chosen}
        if contender.name in taken:  # two laws of the same class name: number the second
            contender = replace(
                contender,
                name=next(f"{contender.name}_{k}" for k in range(2, 99) if f"{contender.name}_{k}" not in taken),
            )
        chosen.append(contender)
    if not chosen:
        raise ConfigError("--controllers: name at least one")
    return tuple(chosen)


#: (contender, seed) pairs run side by side by ``compare``. Measured on 2 cores,
#: the default compare (50 lockstep runs) on one tree: 140 s one at a time,
#: 90–96 s with 2 workers, 76 s with 3; the figures of every run the same.
#: (With 2, about 1.55 of the 2 cores were busy; with 3, 1.8.)
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
    """Every contender (``controllers``: :func:`contenders`) on the sine and on the step, ``seeds``
    seeds each, in sim-time lockstep; with ``in_process``, on the in-process loop, one after the other.

    ``workers`` (contender, seed) pairs run at once, each in a worker process
    of its own with a ROS domain of its own (:func:`worker_domain`);
    ``workers=1`` runs them one after the other in this process, in the
    caller's domain. A lockstep run's figures depend only on its seed, so
    both give the same table. The progress line of a pair is printed as it
    starts. A failed run raises RuntimeError naming its directory, once the
    pairs under way have ended.
    """
    chosen = contenders(controllers)
    out.mkdir(parents=True, exist_ok=True)
    pairs = [(replace(contender, robot=robot), seed) for contender in chosen for seed in range(seeds)]
    if in_process:
        figures = {}
        for contender, seed in pairs:
            progress(f"{contender.name}: seed {seed}")
            figures[contender.name, seed] = run_pair_in_process(contender, seed, sine_duration_s, amplitude)
    elif workers <= 1:
        figures = {}
        for contender, seed in pairs:
            progress(f"{contender.name}: seed {seed}")
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
    (out / "compare.md").write_text(
        render_compare(table, seeds, sine_duration_s, amplitude, robot, chosen, in_process=in_process)
    )
    plot_compare(table, out / "compare.png")
    return table
