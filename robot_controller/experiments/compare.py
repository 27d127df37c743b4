"""The controller comparison (``robot-controller compare``): each contender on the sine and on a step, over several
seeds, on sim time (pairs side by side in worker processes, each on a ROS domain of its own) or on the in-process
loop; the table as ``compare.json``, ``compare.md`` and ``compare.png``.

A contender is a named configuration (:data:`CONTENDERS`, and ``default``: the default preset as it is) or a law
(``module:Class``, ``file.py:Class`` or an installed law's name, with the default stack). A configuration's name
wins over an installed law's (``pid``, ``lqr``)."""

from __future__ import annotations

import multiprocessing
import os
import signal
from collections.abc import Callable, Sequence
from concurrent import futures
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError
from robot_controller.experiments import laws
from robot_controller.experiments.reporting import pyplot
from robot_controller.experiments.reporting import table as markdown_table
from robot_controller.experiments.step import (
    STEP_AFTER_S,
    STEP_LEAD_S,
    check_step,
    run_and_score,
    step_params,
    step_response,
    tick_step_figures,
)
from robot_controller.parameters.schema import LOCKSTEP_END_MARGIN_S
from robot_controller.scoring import report

#: (contender, seed) pairs run side by side by ``compare``: three keep two cores busy.
COMPARE_WORKERS = 3
COMPARED = {
    "sine": ("tracking_rms_rad", "tracking_max_rad", "start_tracking_max_rad"),
    "step": ("overshoot_pct", "settling_time_s", "rise_time_s", "peak_torque_nm", "steady_state_error_rad"),
}


@dataclass(frozen=True)
class Contender:
    name: str
    description: str
    preset: str
    overrides: dict[str, Any]
    robot: str = "one_dof"

    def params(self) -> cfg.Params:
        """Its preset on its robot, its ``pid_controller`` overrides over it."""
        return cfg.merge(cfg.load_stack(self.preset, robot=self.robot), {"pid_controller": self.overrides})


def _stack(controller_type: str, feedforward: str, estimator: str) -> dict[str, str]:
    return {"controller_type": controller_type, "feedforward": feedforward, "estimator": estimator}


CONTENDERS = (
    Contender("tutorial", "the tutorial's controller as written", "tutorial", {}),
    Contender("pid", "PID, derivative on velocity error", "default", _stack("pid", "none", "none")),
    Contender("pid_ff", "PID + model feedforward", "default", _stack("pid", "full", "none")),
    Contender("pid_ff_kf", "PID + feedforward + Kalman filter", "default", _stack("pid", "full", "kalman")),
    Contender("lqr", "LQR + feedforward + Kalman filter (default)", "default", _stack("lqr", "full", "kalman")),
)
#: Configurations by name for ``--controllers``: the contenders, and the default preset as it is.
NAMED = {c.name: c for c in CONTENDERS} | {"default": Contender("default", "the default preset", "default", {})}


def law_contender(spec: str) -> Contender:
    """A law (``--controller SPEC``) with the default stack, named by its class."""
    return Contender(
        laws.label(spec), f"{spec} with the default stack", "default", {"controller_type": laws.controller_type(spec)}
    )


def contenders(names: Sequence[str] | None = None) -> tuple[Contender, ...]:
    """The contenders ``names`` (``--controllers``) name, in order; every contender for None.

    :raises ConfigError: a name that is neither a configuration nor a law
    """
    if names is None:
        return CONTENDERS
    chosen: list[Contender] = []
    for name in (n.strip() for n in names):
        if name in NAMED:
            contender = NAMED[name]
        elif laws.is_law(name):
            contender = law_contender(name)
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


def run_pair(
    contender: Contender,
    seed: int,
    out: Path,
    sine_duration_s: float,
    amplitude: float,
    domain_id: int | None = None,
    between_runs: Callable[[], None] = lambda: None,
) -> dict[str, float]:
    """One contender, one seed: the sine run, then the step run, on the real graph on sim time. The compared
    figures, keyed as in the table. ``between_runs`` is called after each run (a worker stops there when asked to)."""
    base = contender.params()
    params = cfg.merge(base, {"sensor_node": {"seed": seed}})
    sine, _ = run_and_score(
        params, out / contender.name / f"sine_{seed}", duration_s=sine_duration_s, sim_time=True, domain_id=domain_id
    )
    between_runs()
    step_out = out / contender.name / f"step_{seed}"
    try:
        shape = {"amplitude": amplitude, "shaping": "min_time"}
        checked = check_step(base, **shape, sim_time=True, seed=seed, domain_id=domain_id)
        figures = step_response(checked, step_out, **shape)
    except ValueError as exc:  # no step in the recording
        raise RuntimeError(f"run in {step_out} failed: {exc}") from None
    between_runs()
    return _compared(sine, figures)


def run_pair_in_process(contender: Contender, seed: int, sine_duration_s: float, amplitude: float) -> dict[str, float]:
    """:func:`run_pair` on the in-process loop: the same parameters, the sim-time graph's computation, no ROS, scored
    as the graph's runs are. Its first tick is the graph's first (the arm's start, the filter's first reading, the
    planner's time 0 alike), so the step comes as the graph's does, ``step.STEP_LEAD_S`` after it; each run lasts as
    long as the graph records its run (the state at the sine's end is scored, as the bag holds it; a step late on a
    slow planner's grid is scored over its whole ``STEP_AFTER_S``)."""
    from robot_controller.experiments import inprocess
    from robot_controller.scoring import loop_scoring

    base = contender.params()
    period_s = 1.0 / base["pid_controller"]["control_rate_hz"]
    sine_run = inprocess.simulate(base, duration_s=sine_duration_s + period_s, seed=seed)
    sine = loop_scoring.tracking(sine_run, sine_duration_s, period_s)
    stepped = step_params(base, amplitude, "min_time")
    result = inprocess.simulate(stepped, duration_s=STEP_LEAD_S + STEP_AFTER_S + LOCKSTEP_END_MARGIN_S, seed=seed)
    offset = cfg.per_joint("offset", stepped["trajectory_planner"]["offset"], result.reference.shape[1])
    try:
        step = tick_step_figures(
            result.tick_time_s, result.reference, result.true_position, result.command, amplitude, offset, STEP_AFTER_S
        )
    except ValueError as exc:
        raise RuntimeError(f"the in-process step run of {contender.name}: {exc}") from None
    return _compared(sine, step)


def _compared(sine: dict[str, float], step: dict[str, float]) -> dict[str, float]:
    return {f"sine_{k}": sine[k] for k in COMPARED["sine"]} | {f"step_{k}": step[k] for k in COMPARED["step"]}


def render_compare(
    table,
    seeds: int,
    sine_duration_s: float,
    amplitude: float,
    robot: str = "one_dof",
    chosen: Sequence[Contender] | None = None,
    in_process: bool = False,
) -> str:
    names = {c.name: c.description for c in (chosen or CONTENDERS)}
    how = "the in-process loop (no ROS; the sim-time graph's runs, scored alike)" if in_process else "sim time"
    columns = [
        ("sine_tracking_rms_rad", "sine RMS, true [rad]", "{:.5f}"),
        ("sine_tracking_max_rad", "sine max [rad]", "{:.4f}"),
        ("sine_start_tracking_max_rad", "sine start max [rad]", "{:.4f}"),
        ("step_overshoot_pct", "step overshoot [%]", "{:.2f}"),
        ("step_settling_time_s", "settling 2 % [s]", "{:.3f}"),
        ("step_rise_time_s", "rise 10–90 % [s]", "{:.3f}"),
        ("step_peak_torque_nm", "peak torque [N·m]", "{:.2f}"),
    ]
    lines = [
        "# Controller comparison",
        "",
        f"Robot {robot}, {how}, {seeds} seed(s) each: its default sine for "
        f"{sine_duration_s:g} s (its first 2 s, the start, apart), a {amplitude} rad step of every joint shaped to "
        "the fastest move within 60 rad/s² (slowed if the torque needs it). Figures on the TRUE joint angle, the "
        "worst joint's; mean ± standard deviation over seeds.",
        "",
    ]
    rows = []
    for name, row in table.items():
        cells = [f"**{name}**: {names[name]}"]
        for key, _, fmt in columns:
            stats = row[key]
            if not np.isfinite(stats["mean"]):
                cells.append(f"never, in {STEP_AFTER_S:g} s" if "settling" in key else "n/a")
            else:
                cells.append(f"{fmt.format(stats['mean'])} ± {fmt.format(stats['std'])}")
        rows.append(cells)
    lines += [
        markdown_table(["controller", *(c[1] for c in columns)], rows),
        "",
        "Targets on the reference arm (one_dof): sine RMS ≤ 0.0015 rad; step overshoot ≤ 2 %, settling ≤ 0.25 s, "
        "|torque| ≤ 10 N·m throughout.",
        "",
    ]
    return "\n".join(lines)


def plot_compare(table, path: Path) -> None:
    plt = pyplot()
    names = list(table)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), constrained_layout=True)
    for ax, key, label, log in (
        (axes[0], "sine_tracking_rms_rad", "sine RMS error, true angle [rad]", True),
        (axes[1], "step_settling_time_s", "step settling time (2 %) [s]", False),
        (axes[2], "step_overshoot_pct", "step overshoot [%]", False),
    ):
        means = [table[n][key]["mean"] for n in names]
        stds = [table[n][key]["std"] for n in names]
        ax.bar(names, means, yerr=stds, capsize=3, color=["#999"] + ["#4c72b0"] * (len(names) - 1))
        if log:
            ax.set_yscale("log")
        ax.set_title(label, fontsize=10)
        ax.tick_params(axis="x", rotation=30)
        ax.grid(alpha=0.3, axis="y")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run_side_by_side(
    pairs, out: Path, sine_duration_s: float, amplitude: float, progress, workers: int
) -> dict[tuple[str, int], dict[str, float]]:
    """Run the pairs on ``workers`` spawned processes (the launcher forks the nodes, so its process must be
    single-threaded), never more at once than workers: each progress line is printed as its pair starts.
    Ctrl-C or the caller's death ends each worker's run cleanly."""
    context = multiprocessing.get_context("spawn")
    slots = context.Value("i", 0)
    try:
        base = int(os.environ.get("ROS_DOMAIN_ID", "0"))
    except ValueError:
        base = 0
    figures: dict[tuple[str, int], dict[str, float]] = {}
    todo = iter(pairs)
    running: dict[futures.Future, tuple[str, int]] = {}
    pool = futures.ProcessPoolExecutor(
        max_workers=min(workers, len(pairs)) or 1, mp_context=context, initializer=_init_worker, initargs=(slots, base)
    )
    try:

        def start_next() -> None:
            for contender, seed in todo:
                progress(f"{contender.name}: seed {seed}")
                future = pool.submit(_compare_pair_in_worker, contender, seed, out, sine_duration_s, amplitude)
                running[future] = (contender.name, seed)
                return

        for _ in range(workers):
            start_next()
        while running:
            done, _ = futures.wait(running, return_when=futures.FIRST_COMPLETED)
            for future in done:
                key = running.pop(future)
                figures[key] = future.result()  # a failed run raises here: RuntimeError naming its directory
                start_next()
    finally:
        # On a failure (or Ctrl-C) the pairs under way end first, their nodes stopped cleanly.
        pool.shutdown(wait=True, cancel_futures=True)
    return figures


# In a worker process: its ROS domain, and whether Ctrl-C arrived during a task.
_domain_id: int | None = None
_interrupted = False
_parent_pid: int | None = None


def _init_worker(slots, base: int) -> None:
    global _domain_id, _parent_pid
    with slots.get_lock():
        slot = slots.value
        slots.value += 1
    _domain_id = (base - 1 + slot) % 101 + 1  # the caller's for slot 0, the next ones after, within 1..101
    _parent_pid = os.getppid()
    # Ctrl-C reaches the whole process group: idle workers leave it to the caller.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    # If the caller dies, SIGTERM: the launcher stops the current run's nodes as for Ctrl-C.
    from robot_controller.runner import forking

    forking.die_with_parent()


def _on_sigint(_signum, _frame) -> None:
    global _interrupted
    _interrupted = True
    raise KeyboardInterrupt


def _stop_if_asked() -> None:
    """In a worker, after a run the launcher ended on Ctrl-C or SIGTERM: go on to no next run."""
    if _interrupted or (_parent_pid is not None and os.getppid() != _parent_pid):
        raise KeyboardInterrupt


def _compare_pair_in_worker(
    contender: Contender, seed: int, out: Path, sine_duration_s: float, amplitude: float
) -> dict[str, float]:
    global _interrupted
    _interrupted = False
    signal.signal(signal.SIGINT, _on_sigint)
    try:
        return run_pair(
            contender, seed, out, sine_duration_s, amplitude, domain_id=_domain_id, between_runs=_stop_if_asked
        )
    finally:
        signal.signal(signal.SIGINT, signal.SIG_IGN)
