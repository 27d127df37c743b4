"""``robot-controller faults``: freeze (``SIGSTOP``) or kill each node in turn mid-motion (the sine's
peak speed) and measure what the arm did: deviation from the band the reference sweeps, time to re-acquire
the plan, peak torque, brakes. A freeze strikes the default run (the paced world) or, with ``wall_clock``, the
hardware-strict one; a kill is respawned, on the wall clock (a respawned simulator would restart the paced
world's time). docs/design.md §4 says what each loss must cause."""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.core import metrics
from robot_controller.core.metrics import in_units
from robot_controller.experiments.reporting import fmt, table
from robot_controller.runner import launcher, plan
from robot_controller.runner.options import RunOptions
from robot_controller.scoring import plots, report, scored_run

NODES = ("simulator", "motor_node", "sensor_node", "pid_controller", "trajectory_planner")
DURATIONS_S = (0.05, 0.5, 3.0)
QUICK_CASES = (("sensor_node", 0.5), ("pid_controller", 0.5))
FAULT_AT_S = 5.0
AFTER_S = 4.0
REACQUIRED_RAD = 0.002
REACQUIRED_HOLD_S = 0.1
GOAL_DEVIATION_RAD = 0.1


@dataclass(frozen=True)
class Case:
    node: str
    duration_s: float  #: how long it is frozen (SIGSTOP); 0 for a kill
    kind: str = "SIGSTOP"  #: or "SIGKILL": the launcher respawns the node

    @property
    def name(self) -> str:
        return f"{self.node}_stop_{self.duration_s:g}s" if self.kind == "SIGSTOP" else f"{self.node}_kill"


class Freezer:
    """A launcher watcher: ``SIGSTOP`` the node at ``at_s``, ``SIGCONT`` it later; when it did both, on the system
    clock (a wall-clock run's time) and CLOCK_MONOTONIC (mapped to a paced world's time after the run)."""

    def __init__(self, case: Case, at_s: float) -> None:
        self.case, self.at_s = case, at_s
        self.started = False
        self.stopped_at = self.resumed_at = float("nan")
        self.stopped_monotonic = self.resumed_monotonic = float("nan")
        self.thread: threading.Thread | None = None

    def __call__(self, elapsed_s: float, pids: dict[str, int]) -> None:
        if self.started or elapsed_s < self.at_s:
            return
        self.started = True
        self.thread = threading.Thread(target=self._freeze, args=(pids[self.case.node],), daemon=True)
        self.thread.start()

    def _freeze(self, pid: int) -> None:
        if self.case.kind == "SIGKILL":
            os.kill(pid, signal.SIGKILL)
            self.stopped_at, self.stopped_monotonic = time.time(), time.monotonic()
            self.resumed_at, self.resumed_monotonic = self.stopped_at, self.stopped_monotonic
            return
        try:
            os.kill(pid, signal.SIGSTOP)
            self.stopped_at, self.stopped_monotonic = time.time(), time.monotonic()
            time.sleep(self.case.duration_s)
        finally:
            os.kill(pid, signal.SIGCONT)
            self.resumed_at, self.resumed_monotonic = time.time(), time.monotonic()


def fault_time_s(params: cfg.Params, earliest_s: float = FAULT_AT_S) -> float:
    """When to strike, s after the loop closes: the sine's first zero crossing (peak speed) from ``earliest_s``."""
    planner = params["trajectory_planner"]
    if planner["mode"] != "sine":
        return earliest_s
    half_period_s = 0.5 / float(planner["frequency_hz"])
    return float(np.ceil(earliest_s / half_period_s - 1e-9) * half_period_s)


def case_figures(
    recording: report.Recording, fault_start_s: float, fault_end_s: float, units: list[str] | None = None
) -> dict[str, Any]:
    """What the arm did from the fault on (times on the run's clock, s): per joint in its unit (``units``: "rad",
    the default, or "m"), and on the worst revolute (``_rad``) and prismatic (``_m``) joint (``metrics.by_unit``)."""
    s = recording.state
    planned_t, planned_q = recording.planned_time_s, recording.planned_position
    true_t, true_q = recording.true_time_s, recording.true_position
    low, high = np.min(planned_q, axis=0), np.max(planned_q, axis=0)
    after = true_t >= fault_start_s
    outside_per_joint = np.maximum(0.0, np.maximum(true_q - high, low - true_q))
    planned = np.column_stack([np.interp(true_t, planned_t, planned_q[:, j]) for j in range(planned_q.shape[1])])
    error_per_joint = np.abs(true_q - planned)
    error = np.max(error_per_joint, axis=1)
    # Back: the first moment after the fault from which the error stays within 2 mrad (or mm) for REACQUIRED_HOLD_S.
    reacquire_s = float("nan")
    within = (true_t >= fault_end_s) & (error < REACQUIRED_RAD)
    for start in np.flatnonzero(within):
        window = (true_t >= true_t[start]) & (true_t < true_t[start] + REACQUIRED_HOLD_S)
        if true_t[-1] >= true_t[start] + REACQUIRED_HOLD_S and np.all(within[window]):
            reacquire_s = float(true_t[start] - fault_end_s)
            break
    # Up to 0.1 s before the last tick: the nodes stopping one by one at the end is not the fault's doing.
    last_tick_s = s["time_s"][-1] - 0.1
    ticks = (s["time_s"] >= fault_start_s) & (s["time_s"] <= last_tick_s)
    # The brakes' state in force at the fault's start, and each change after: in the paced world the brakes are
    # stamped with the world's tick, which can fall a moment before a start mapped from the wall clock.
    brakes_s = recording.brakes_time_s
    in_force_s = brakes_s[brakes_s <= fault_start_s].max(initial=-np.inf)
    braked = (brakes_s >= in_force_s) & (brakes_s <= last_tick_s) & np.any(recording.brakes > 0.5, axis=1)
    units = units or ["rad"] * true_q.shape[1]
    nan = np.full(true_q.shape[1], np.nan)
    deviation = np.max(outside_per_joint[after], axis=0).tolist() if np.any(after) else nan.tolist()
    off_plan = np.max(error_per_joint[after], axis=0).tolist() if np.any(after) else nan.tolist()
    missed = [  # (NaN: the arm's state after the fault was not recorded)
        f"{name} left its band by {outside:.4f} {unit} (goal ≤ {GOAL_DEVIATION_RAD:g} {unit})"
        for name, outside, unit in zip(recording.joint_names, deviation, units, strict=True)
        if not outside <= GOAL_DEVIATION_RAD
    ]
    return {
        "max_deviation_per_joint": deviation,
        **metrics.by_unit("max_deviation", deviation, units),
        **metrics.by_unit("max_error_from_plan", off_plan, units),
        "reacquire_s": reacquire_s,
        **metrics.peak_torque(s["command"][ticks] if np.any(ticks) else np.zeros((1, len(units))), units),
        "brake_engaged": bool(np.any(braked)),
    } | ({"band_missed": "; ".join(missed)} if missed else {})


def world_of(case: Case, wall_clock: bool) -> str:
    """Where ``case`` runs: "paced" (the default run's world) or "wall clock" (a kill: respawned there)."""
    return "wall clock" if wall_clock or case.kind == "SIGKILL" else "paced"


def run_case(case: Case, out: Path, params: cfg.Params, *, wall_clock: bool = False) -> dict[str, Any]:
    """One fault on one run: in the paced world (the default run's), or on the wall clock (``wall_clock``, and
    every kill)."""
    at_s = fault_time_s(params)
    freezer = Freezer(case, at_s)
    world = world_of(case, wall_clock)
    options = RunOptions(at_s + case.duration_s + AFTER_S, respawn=case.kind == "SIGKILL", paced=world == "paced")
    checked = plan.check(params, options)
    result = launcher.launch(checked, out, watcher=freezer)
    result.raise_if_interrupted()
    if freezer.thread is not None:
        freezer.thread.join()
    entry: dict[str, Any] = {
        "case": case.name,
        "node": case.node,
        "fault": case.kind,
        "duration_s": case.duration_s,
        "world": world,
        "exit_code": result.exit_code,
    }
    if not scored_run.has_ticks(result):
        return entry | {"failure": result.failure or "no recording"}
    scored = scored_run.score_launched(checked, result)
    recording, values, units = scored.recording, scored.metrics, scored.metrics["joint_units"]
    if world == "paced":  # the run's time is the world's: the freeze's instants mapped onto it
        start_s = result.world_time_at(freezer.stopped_monotonic)
        # (a world paused at once, its simulator frozen: the start, carried on at 1×, can pass the end by a tick)
        end_s = max(start_s, result.world_time_at(freezer.resumed_monotonic, resuming=True))
    else:
        start_s, end_s = freezer.stopped_at, freezer.resumed_at
    entry.update(case_figures(recording, start_s, end_s, units))
    entry["fault_s"] = [start_s, end_s]  #: when it struck and ended, on the run's clock (the recording's)
    entry.update({key: values[key] for key in ("tracking_max_rad", "tracking_max_m") if key in values})
    if result.failure:
        entry["failure"] = result.failure
    report.write_metrics(out / "metrics.json", values)
    title = f"{case.node} frozen {case.duration_s:g} s ({world})"
    plots.plot_tracking(recording, out / "tracking.png", title=title, units=units)
    return entry


def cases(quick: bool) -> list[Case]:
    if quick:
        return [Case(node, d) for node, d in QUICK_CASES]
    return [Case(node, d) for node in NODES for d in DURATIONS_S] + [Case(node, 0.0, "SIGKILL") for node in NODES]


def faults(
    out: Path,
    *,
    quick: bool = False,
    progress: Callable[[str], None] = print,
    robot: str = "one_dof",
    controller: str | None = None,
    wall_clock: bool = False,
) -> list[dict[str, Any]]:
    """Every case (:func:`cases`) on the default stack; ``controller``: with that law (``--controller``);
    ``wall_clock``: freezes on the hardware-strict clock, not in the paced world (``--wall-clock``)."""
    from robot_controller.experiments.laws import with_controller

    params = with_controller(cfg.load_stack(robot=robot), controller)
    out.mkdir(parents=True, exist_ok=True)
    entries = []
    for case in cases(quick):
        progress(
            f"{case.node}: "
            + (f"SIGSTOP for {case.duration_s:g} s" if case.kind == "SIGSTOP" else "SIGKILL, respawned")
            + f" at t = {fault_time_s(params):g} s ({world_of(case, wall_clock)})"
        )
        entries.append(run_case(case, out / case.name, params, wall_clock=wall_clock))
    summary = {"robot": robot, "controller_type": params["pid_controller"]["controller_type"], "cases": entries}
    report.write_metrics(out / "faults.json", summary | headline(entries) | {"failed": failed(entries)})
    (out / "faults.md").write_text(render(entries, robot, params, wall_clock=wall_clock))
    return entries


def headline(entries: list[dict[str, Any]]) -> dict[str, Any]:
    """The worst deviation of every case: a revolute joint's, and a prismatic one's (``_m``) if any."""
    worst = {
        f"worst_{key}": max((e[key] for e in entries if np.isfinite(e.get(key, np.nan))), default=float("nan"))
        for key in ("max_deviation_rad", "max_deviation_m")
        if key.endswith("rad") or any(key in e for e in entries)
    }
    return worst | {
        "goal_max_deviation_rad": GOAL_DEVIATION_RAD,
        "all_cases_ran": all("failure" not in e for e in entries),
    }


def failed(entries: list[dict[str, Any]]) -> list[str]:
    """One line per case that missed its goal: a joint out of its band by more than ``GOAL_DEVIATION_RAD`` (or m),
    or a run that failed."""
    return [
        f"{e['case']}: {e['band_missed'] if e.get('band_missed') else e['failure']}"
        for e in entries
        if e.get("band_missed") or e.get("failure")
    ]


def render(
    entries: list[dict[str, Any]], robot: str = "one_dof", params: cfg.Params | None = None, *, wall_clock: bool = False
) -> str:
    def num(value: Any, spec: str) -> str:
        return fmt(value, spec, "n/a")

    top = headline(entries)
    params = params or cfg.load_stack(robot=robot)
    planner = params["trajectory_planner"]
    units = report.arm_units(params["simulator"]["urdf_path"])
    slides = "m" in units  # a prismatic joint: its figures in m and N beside the revolute joints'
    worst = f"{num(top['worst_max_deviation_rad'], '{:.4f}')} rad"
    worst += f", {num(top.get('worst_max_deviation_m'), '{:.4f}')} m" * slides
    world = (
        "freezes on the wall clock (`--wall-clock`: the drive on this host's clock, any late command refused)"
        if wall_clock
        else "freezes in the paced world (the default run's: its clock keeps pace with the wall clock)"
    )
    kills = ", kills on the wall clock" if any(e["fault"] == "SIGKILL" for e in entries) else ""
    lines = [
        "# Faults: each node frozen mid-motion",
        "",
        f"Robot {robot}, default preset (controller_type {params['pid_controller']['controller_type']}), "
        f"{world}{kills}; sine of {in_units(planner['amplitude'], units)} at "
        f"{planner['frequency_hz']:g} Hz. At {fault_time_s(params):g} s (peak speed) one node gets "
        "SIGSTOP, then SIGCONT after the duration; or SIGKILL, and the launcher respawns it "
        "(`run --respawn`, wall clock: a respawned simulator would restart the paced world's time). "
        f"Deviation: how far the TRUE {'position' if slides else 'angle'} left the band the "
        f"reference sweeps, on the worst joint. Re-acquired: every joint back within 2 mrad{' (2 mm)' * slides} "
        "of the planned trajectory, after the fault ended.",
        "",
        f"**Worst deviation: {worst}** (goal ≤ {GOAL_DEVIATION_RAD:g} rad{f', {GOAL_DEVIATION_RAD:g} m' * slides}"
        " in every case).",
        "",
        *(f"**FAILED: {line}**\n" for line in failed(entries)),
    ]
    fault_text = {"SIGSTOP": "frozen {:g} s", "SIGKILL": "killed, respawned"}
    shown = (("max_deviation", "{:.4f}", "deviation"), ("max_error_from_plan", "{:.3f}", "largest error from the plan"))
    figures = [(f"{key}_{u}", spec, f"{name} [{u}]") for key, spec, name in shown for u in ("rad", "m")[: 1 + slides]]
    figures += [("reacquire_s", "{:.2f}", "re-acquired after [s]"), ("peak_torque_nm", "{:.1f}", "peak torque [N·m]")]
    figures += [("peak_force_n", "{:.1f}", "peak force [N]")] * slides
    rows = [
        [e["node"], fault_text[e["fault"]].format(e["duration_s"]), e.get("world", "wall clock")]
        + [num(e.get(k), spec) for k, spec, _ in figures]
        + ["yes" if e.get("brake_engaged") else "no", f"{e.get('exit_code')} {e.get('failure', '')}".rstrip()]
        for e in entries
    ]
    headers = " | ".join(["node", "fault", "world", *(heading for *_, heading in figures), "brakes engaged", "exit"])
    lines.append(table(headers, rows))
    return "\n".join(lines) + "\n"
