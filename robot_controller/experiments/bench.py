"""``robot-controller bench``: how steadily and how fast the loop runs.

Every scenario is a real run (five processes over DDS, or one), scored from
its recording like any other; the core figures time the in-process loop and
a vectorised batch. Writes ``bench.json`` (flat keys) and ``bench.md``.
"""
from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.runner import forking
from robot_controller.experiments import hop_bench
from robot_controller.experiments import inprocess
from robot_controller.runner import launcher
from robot_controller.scoring import report
from robot_controller.core.batch import ArmConstants, run_batch
from robot_controller.core.pid import PidConfig
from robot_controller.core.plant import ArmDynamics
from robot_controller.core.trajectory import make_trajectory


@dataclass(frozen=True)
class Target:
    key: str
    limit: float
    at_most: bool  # True: figure ≤ limit is met; False: figure ≥ limit
    text: str


TARGETS = (
    Target("soak_missed", 2, True, "soak (100 Hz wall clock, default preset): at most 2 missed cycles"),
    Target("soak_stalls_30ms", 0, True, "soak: no period over 30 ms"),
    Target("soak_watchdog_ticks", 0, True, "soak: the watchdog never cuts the torque"),
    Target("soak_jitter_p99_ms", 0.5, True, "soak: p99 of the period's distance from 10 ms ≤ 0.5 ms at the controller"),
    Target("soak_tracking_max_rad", 0.02, True, "soak: tracking error never over 20 mrad"),
    Target("soak_rss_growth_mb", 5.0, True, "soak: no process grows by more than 5 MB"),
    Target("cpu_pct_recorder", 10.0, True, "recorder ≤ 10 % of one core"),
    Target("cpu_pct_total", 40.0, True, "whole stack, recorder included, ≤ 40 % of one core"),
    Target("lockstep_rtf_vs_hop_limit", 0.7, False, "lockstep RTF (five processes) ≥ 70 % of the round-trip limit"),
    Target("wall100_missed", 0, True, "100 Hz wall clock: zero missed cycles"),
    Target("wall100_jitter_p99_ms", 0.5, True, "100 Hz: p99 jitter ≤ 0.5 ms"),
    Target("wall100_loaded_missed", 0, True, "… with the other core loaded: zero missed cycles"),
    Target("wall100_loaded_jitter_p99_ms", 0.5, True, "… with the other core loaded: p99 jitter ≤ 0.5 ms"),
    Target("wall100_latency_p99_ms", 1.0, True, "latency sensor stamp → motor p99 ≤ 1 ms"),
    Target("wall1k_missed_pct", 0.1, True, "1 kHz in one process: < 0.1 % missed cycles"),
    Target("lockstep_rtf_multi", 20.0, False, "lockstep RTF ≥ 20, five processes"),
    Target("lockstep_rtf_single", 100.0, False, "lockstep RTF ≥ 100, one process"),
    Target("batch_sim_s_per_s", 10_000.0, False, "batch ≥ 10,000 simulated s per wall s"),
)


def _wall_run(params: cfg.Params, out: Path, duration_s: float, *, single_process: bool = False,
              sim_time: bool = False) -> dict[str, Any]:
    result = launcher.launch(params, out_dir=out, duration_s=duration_s, single_process=single_process,
                             sim_time=sim_time)
    result.raise_if_interrupted()
    if result.exit_code != 0 and not result.message_counts.get("/controller/state"):
        return {"failure": result.failure}
    values = report.score(report.read_recording(result.bag_dir),
                          nominal_period_s=1.0 / params["pid_controller"]["control_rate_hz"],
                          window_s=duration_s if sim_time else None)
    values["real_time_factor"] = result.real_time_factor
    if result.failure:
        values["failure"] = result.failure  # scored as far as it ran, and said so
    values.update(result.usage)
    values["unrecorded_messages"] = sum(result.unrecorded.values())
    report.write_metrics(out / "metrics.json", values)
    return values


def _kilohertz(params: cfg.Params) -> cfg.Params:
    """The reference scenario with the control loop, sensor and true state at 1 kHz."""
    return cfg.merge(params, {"pid_controller": {"control_rate_hz": 1000.0},
                              "sensor_node": {"rate_hz": 1000.0},
                              "simulator": {"publish_rate_hz": 1000.0},
                              "trajectory_planner": {"publish_rate_hz": 1000.0}})


def _ordinary_child() -> None:
    """Normal scheduling, and gone when the bench is (even if it is killed)."""
    os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    forking.die_with_parent()


class BusyCore:
    """A process that keeps one core busy for as long as the context lasts."""

    def __enter__(self) -> BusyCore:
        # Ordinary scheduling, whatever this process runs at: it is the machine's
        # other work, not a real-time task.
        self.process = subprocess.Popen([sys.executable, "-c", "while True: pass"], preexec_fn=_ordinary_child)
        return self

    def __exit__(self, *exc_info) -> None:
        self.process.kill()
        self.process.wait()


def core_steps_per_s(duration_s: float) -> float:
    params = cfg.load_stack()
    start = time.perf_counter()
    result = inprocess.simulate(params, duration_s=duration_s, seed=0)
    return len(result.tick_time_s) / (time.perf_counter() - start)


def batch_sim_s_per_s(batch: int, duration_s: float) -> tuple[float, float]:
    """Simulated seconds per wall second of ``batch`` gain sets at once; also the best RMS found."""
    rng = np.random.default_rng(0)
    pid = PidConfig(kp=rng.uniform(10, 100, (batch, 1)), ki=rng.uniform(0, 20, (batch, 1)),
                    kd=rng.uniform(1, 8, (batch, 1)), output_limit=[10.0], integral_limit=[10.0],
                    anti_windup="conditional_integration", derivative_source="velocity_error")
    params = cfg.load_stack()
    start = time.perf_counter()
    rms = run_batch(constants=ArmConstants.from_dynamics(ArmDynamics(resources.default_urdf())), pid_config=pid,
                    trajectory=make_trajectory("sine", joint_count=1), sensor=cfg.sensor_config(params["sensor_node"]),
                    rng=rng, duration_s=duration_s)
    return batch * duration_s / (time.perf_counter() - start), float(np.min(rms))


SOAK_S, QUICK_SOAK_S = 600.0, 20.0


def soak(params: cfg.Params, out: Path, soak_s: float) -> dict[str, Any]:
    """The default run for ``soak_s`` of wall clock: stalls, watchdog, worst
    tracking, memory growth and every process's CPU share. Short runs hide
    stalls: the kernel's throttling and the machine's other work come by
    every few tens of seconds."""
    values = _wall_run(params, out, soak_s)
    figures = {f"soak_{key}": values.get(key) for key in (
        "missed_cycles", "stalls_30ms", "watchdog_ticks", "jitter_p50_ms", "jitter_p99_ms", "jitter_max_ms",
        "tracking_rms_rad", "tracking_max_rad", "latency_p50_ms", "latency_p99_ms", "control_rate_hz",
        "unrecorded_messages")}
    figures["soak_missed"] = figures.pop("soak_missed_cycles")
    growth = [v for k, v in values.items() if k.startswith("rss_growth_mb_") and k != "rss_growth_mb_launcher"]
    figures["soak_rss_growth_mb"] = max(growth) if growth else None
    figures.update({k: v for k, v in values.items() if k.startswith("cpu_pct_")})
    return figures


def bench(out_dir: Path, *, quick: bool = False, soak_s: float | None = None,
          progress: Callable[[str], None] = print) -> dict[str, Any]:
    out_dir.mkdir(parents=True, exist_ok=True)
    wall_s, kilo_s, sim_s = (4.0, 3.0, 3.0) if quick else (60.0, 20.0, 60.0)
    soak_s = soak_s if soak_s is not None else (QUICK_SOAK_S if quick else SOAK_S)
    params = cfg.load_stack()
    figures: dict[str, Any] = {"quick": quick, "wall_duration_s": wall_s, "lockstep_sim_s": sim_s, "soak_s": soak_s,
                               "machine": f"{os.cpu_count()} cores, {platform.platform()}",
                               "python": platform.python_version()}

    def take(prefix: str, values: dict[str, Any], keys: dict[str, str]) -> None:
        if "failure" in values:
            figures[f"{prefix}_failure"] = values["failure"]
        for short, key in keys.items():
            figures[f"{prefix}_{short}"] = values.get(key)  # None (null) if the run could not measure it

    timing = {"jitter_p50_ms": "jitter_p50_ms", "jitter_p99_ms": "jitter_p99_ms", "jitter_max_ms": "jitter_max_ms",
              "missed": "missed_cycles", "latency_p50_ms": "latency_p50_ms", "latency_p99_ms": "latency_p99_ms",
              "rate_hz": "control_rate_hz", "tracking_rms_rad": "tracking_rms_rad"}
    progress(f"soak: wall clock 100 Hz, default preset, {soak_s:g} s")
    figures.update(soak(params, out_dir / "soak", soak_s))
    progress(f"wall clock 100 Hz, five processes, {wall_s:g} s")
    take("wall100", _wall_run(params, out_dir / "wall100", wall_s), timing)
    progress(f"wall clock 100 Hz, five processes, other core busy, {wall_s:g} s")
    with BusyCore():
        take("wall100_loaded", _wall_run(params, out_dir / "wall100_loaded", wall_s), timing)
    for mode, single in (("single", True), ("multi", False)):
        progress(f"wall clock 1 kHz, {mode} process, {kilo_s:g} s")
        values = _wall_run(_kilohertz(params), out_dir / f"wall1k_{mode}", kilo_s, single_process=single)
        take(f"wall1k_{mode}", values, {"rate_hz": "control_rate_hz", "jitter_p99_ms": "jitter_p99_ms",
                                        "missed": "missed_cycles"})
        figures[f"wall1k_{mode}_missed_pct"] = (100.0 * values["missed_cycles"] / max(values["control_ticks"], 1)
                                                if "missed_cycles" in values else None)
    figures["wall1k_missed_pct"] = figures["wall1k_single_missed_pct"]
    for mode, single in (("multi", False), ("single", True)):
        progress(f"sim-time lockstep, {mode} process, {sim_s:g} sim s")
        values = _wall_run(params, out_dir / f"lockstep_{mode}", sim_s, single_process=single, sim_time=True)
        take(f"lockstep_{mode}", values, {"tracking_rms_rad": "tracking_rms_rad"})
        figures[f"lockstep_rtf_{mode}"] = values.get("real_time_factor")
    progress("two-process rclpy round trips (the lockstep bound)")
    figures["hop_round_trips_per_s"] = hop_bench.round_trips_per_s(2.0 if quick else 10.0)
    figures["hop_limit_rtf"] = (figures["hop_round_trips_per_s"] / 2
                                / params["pid_controller"]["control_rate_hz"])
    figures["lockstep_rtf_vs_hop_limit"] = (figures["lockstep_rtf_multi"] / figures["hop_limit_rtf"]
                                            if figures["lockstep_rtf_multi"] else None)
    progress("in-process loop (no ROS)")
    figures["core_steps_per_s"] = core_steps_per_s(2.0 if quick else 30.0)
    batch = 1000 if quick else 10_000
    figures["batch_size"] = batch
    figures["batch_sim_s_per_s"], figures["batch_best_tracking_rms_rad"] = batch_sim_s_per_s(
        batch, 2.0 if quick else 10.0)
    (out_dir / "bench.json").write_text(json.dumps(figures, indent=2, sort_keys=True) + "\n")
    (out_dir / "bench.md").write_text(render_markdown(figures))
    return figures


def render_markdown(figures: dict[str, Any]) -> str:
    def fmt(value: Any) -> str:
        if isinstance(value, float):
            return f"{value:.4g}"
        return str(value)

    lines = [f"# robot-controller bench{' (quick)' if figures['quick'] else ''}", "",
             f"Machine: {figures['machine']}, Python {figures['python']}. Wall-clock scenarios "
             f"{figures['wall_duration_s']:g} s each, soak {figures['soak_s']:g} s, lockstep {figures['lockstep_sim_s']:g} "
             "sim s.", "",
             "## Targets", "", "| target | figure | met? |", "|---|---|---|"]
    for target in TARGETS:
        value = figures.get(target.key)
        met = value is not None and (value <= target.limit if target.at_most else value >= target.limit)
        if value is None:
            verdict = "not measured"
        elif met:
            verdict = "yes"
        elif target.at_most:
            verdict = f"no: {fmt(value - target.limit)} over"
        else:
            verdict = f"no: {fmt(value / target.limit)}× of the target"
        lines.append(f"| {target.text} | `{target.key}` = {fmt(value)} | {verdict} |")
    lines += ["", "## All figures", "", "| key | value |", "|---|---|"]
    lines += [f"| `{k}` | {fmt(v)} |" for k, v in sorted(figures.items())]
    return "\n".join(lines) + "\n"
