"""``robot-controller bench``: how steadily and how fast the loop runs.

Every scenario is a real run (five processes over DDS, or one), scored from
its recording like any other; the core figures time the in-process loop and
a vectorised batch. Writes ``bench.json`` (flat keys) and ``bench.md``.

The scenarios are data here (:data:`SCENARIOS`); the runs and timings they
measure with are ``bench_runs``'s, the targets and the markdown
``bench_targets``'s.
"""

from __future__ import annotations

import json
import os
import platform
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robot_controller import parameters as cfg
from robot_controller.scoring import report
from robot_controller_lab import camera_bench, campaign_bench, franka_bench, hop_bench
from robot_controller_lab.bench_runs import (
    BusyCore,
    HostFreezes,
    batch_sim_s_per_s,
    core_steps_per_s,
    kilohertz,
    wall_run,
)
from robot_controller_lab.bench_targets import TARGETS, render_markdown

SOAK_S, QUICK_SOAK_S = 600.0, 20.0
NODE_NAMES = ("simulator", "motor_node", "sensor_node", "pid_controller", "trajectory_planner")
# What every wall-clock scenario reports, and under which metrics key.
TIMING = {
    "jitter_p50_ms": "jitter_p50_ms",
    "jitter_p99_ms": "jitter_p99_ms",
    "jitter_max_ms": "jitter_max_ms",
    "missed": "missed_cycles",  # the loop's own; those the host caused apart
    "missed_host": "missed_cycles_host",
    "latency_p50_ms": "latency_p50_ms",
    "latency_p99_ms": "latency_p99_ms",
    "rate_hz": "control_rate_hz",
    "tracking_rms_rad": "tracking_rms_rad",
}


@dataclass(frozen=True)
class Run:
    """What a scenario is given: the parameters, where to write, how long, what ran before."""

    params: cfg.Params
    out: Path
    duration_s: float
    quick: bool
    figures: dict[str, Any]  #: the figures of the scenarios before this one


@dataclass(frozen=True)
class Scenario:
    """One bench scenario: ``measure`` returns exactly ``keys`` (a figure it could
    not measure is None), so every key of bench.json is declared here."""

    name: str  #: its run folder
    text: str  #: what it is (progress line)
    duration_s: float  #: wall s (sim s in lockstep); 0 when not a timed run
    quick_duration_s: float
    keys: tuple[str, ...]
    measure: Callable[[Run], dict[str, Any]]


def _figures(prefix: str, values: dict[str, Any], keys: dict[str, str]) -> dict[str, Any]:
    figures = {f"{prefix}_{short}": values.get(key) for short, key in keys.items()}
    if "failure" in values:
        figures[f"{prefix}_failure"] = values["failure"]
    return figures


def _soak(run: Run) -> dict[str, Any]:
    """The default run for ``duration_s`` of wall clock: stalls, watchdog, worst
    tracking, memory growth and every process's CPU share. Short runs hide
    stalls: the kernel's throttling and the machine's other work come by
    every few tens of seconds."""
    values = wall_run(run.params, run.out, run.duration_s)
    figures = _figures(
        "soak",
        values,
        {
            **TIMING,
            "stalls_30ms": "stalls_30ms",
            "watchdog_ticks": "watchdog_ticks",
            "tracking_max_rad": "tracking_max_rad",
            "unrecorded_messages": "unrecorded_messages",
        },
    )
    growth = [v for k, v in values.items() if k.startswith("rss_growth_mb_") and k != "rss_growth_mb_launcher"]
    figures["soak_rss_growth_mb"] = max(growth) if growth else None
    figures.update({k: values.get(k) for k in CPU_KEYS})
    return figures


def _wall100(loaded: bool) -> Callable[[Run], dict[str, Any]]:
    def measure(run: Run) -> dict[str, Any]:
        if not loaded:
            return _figures("wall100", wall_run(run.params, run.out, run.duration_s), TIMING)
        with BusyCore():
            return _figures("wall100_loaded", wall_run(run.params, run.out, run.duration_s), TIMING)

    return measure


def _wall1k(single: bool) -> Callable[[Run], dict[str, Any]]:
    mode = "single" if single else "multi"

    def measure(run: Run) -> dict[str, Any]:
        values = wall_run(kilohertz(run.params), run.out, run.duration_s, single_process=single)
        figures = _figures(
            f"wall1k_{mode}",
            values,
            {"rate_hz": "control_rate_hz", "jitter_p99_ms": "jitter_p99_ms", "missed": "missed_cycles"},
        )
        figures[f"wall1k_{mode}_missed_pct"] = (
            100.0 * values["missed_cycles"] / max(values["control_ticks"], 1) if "missed_cycles" in values else None
        )
        if single:
            figures["wall1k_missed_pct"] = figures["wall1k_single_missed_pct"]
        return figures

    return measure


def _lockstep(single: bool) -> Callable[[Run], dict[str, Any]]:
    mode = "single" if single else "multi"

    def measure(run: Run) -> dict[str, Any]:
        values = wall_run(run.params, run.out, run.duration_s, single_process=single, sim_time=True)
        return {
            **_figures(f"lockstep_{mode}", values, {"tracking_rms_rad": "tracking_rms_rad"}),
            f"lockstep_rtf_{mode}": values.get("real_time_factor"),
        }

    return measure


PACED = {
    "missed": "missed_cycles",
    "late_efforts": "late_efforts",
    "watchdog_ticks": "watchdog_ticks",
    "stopped_ticks": "stopped_ticks",
    "host_freezes": "host_freezes",
    "host_freeze_ms_max": "host_freeze_ms_max",
    "tracking_rms_rad": "tracking_rms_rad",
    "tracking_max_rad": "tracking_max_rad",
    "rtf": "real_time_factor",
}


def _paced(frozen: bool) -> Callable[[Run], dict[str, Any]]:
    """The default run (the paced world); ``frozen``: every node frozen together for 50 ms every 5 s."""
    name = "paced_frozen" if frozen else "paced"

    def measure(run: Run) -> dict[str, Any]:
        freezes = HostFreezes() if frozen else None
        values = wall_run(run.params, run.out, run.duration_s, paced=True, watcher=freezes)
        figures = _figures(name, values, PACED)
        if freezes is not None:
            figures["paced_frozen_injected"] = freezes.count
        return figures

    return measure


def _hop(run: Run) -> dict[str, Any]:
    round_trips = hop_bench.round_trips_per_s(run.duration_s)
    limit = round_trips / 2 / run.params["pid_controller"]["control_rate_hz"]
    multi = run.figures.get("lockstep_rtf_multi")
    return {
        "hop_round_trips_per_s": round_trips,
        "hop_limit_rtf": limit,
        "lockstep_rtf_vs_hop_limit": multi / limit if multi else None,
        "hop_message_cpu_us": hop_bench.message_cpu_s(run.duration_s) * 1e6,
    }


def _core(run: Run) -> dict[str, Any]:
    batch = 1000 if run.quick else 10_000
    sim_s_per_s, best = batch_sim_s_per_s(batch, run.duration_s)
    return {
        "core_steps_per_s": core_steps_per_s(run.duration_s),
        "core_steps_per_s_panda": core_steps_per_s(run.duration_s, robot="panda"),
        "batch_size": batch,
        "batch_sim_s_per_s": sim_s_per_s,
        "batch_best_tracking_rms_rad": best,
    }


def _campaign(run: Run) -> dict[str, Any]:
    """A one-joint campaign on 1 and 2 local workers and on a Ray head started for it."""
    return campaign_bench.campaign_figures(run.out, 6 if run.quick else 40, run.duration_s)


def _loop_floor(run: Run) -> dict[str, Any]:
    figures: dict[str, Any] = {}
    for robot in ("one_dof", "panda"):
        timed = campaign_bench.loop_floor(cfg.load_stack(robot=robot), run.duration_s)
        figures.update({f"loop_floor_{robot}_{k}": timed[k] for k in LOOP_FLOOR_FIGURES})
    return figures


CAMPAIGN_KEYS = tuple(
    "campaign_runs campaign_run_s campaign_runs_per_s_1w campaign_runs_per_s_2w campaign_core_share_1w "
    "campaign_core_share_2w campaign_idle_ms_per_run_1w campaign_idle_ms_per_run_2w campaign_runs_per_s_per_worker "
    "campaign_scaling_2w campaign_ray_connect_s "
    "campaign_ray_overhead_ms_per_run".split()
)
LOOP_FLOOR_FIGURES = ("loop_s", "mujoco_s", "loop_vs_floor", "physics_s", "loop_vs_physics", "controller_share")
LOOP_FLOOR_KEYS = tuple(f"loop_floor_{robot}_{k}" for robot in ("one_dof", "panda") for k in LOOP_FLOOR_FIGURES)
CPU_KEYS = tuple(f"cpu_pct_{name}" for name in ("total", "recorder", "launcher", *NODE_NAMES))
_TIMING_KEYS = tuple(TIMING)
SCENARIOS = (
    Scenario(
        "soak",
        "soak: wall clock 100 Hz, default preset",
        SOAK_S,
        QUICK_SOAK_S,
        tuple(
            f"soak_{k}"
            for k in (
                *_TIMING_KEYS,
                "stalls_30ms",
                "watchdog_ticks",
                "tracking_max_rad",
                "unrecorded_messages",
                "rss_growth_mb",
            )
        )
        + CPU_KEYS,
        _soak,
    ),
    Scenario(
        "wall100",
        "wall clock 100 Hz, five processes",
        60.0,
        4.0,
        tuple(f"wall100_{k}" for k in _TIMING_KEYS),
        _wall100(loaded=False),
    ),
    Scenario(
        "wall100_loaded",
        "wall clock 100 Hz, five processes, the other core busy",
        60.0,
        4.0,
        tuple(f"wall100_loaded_{k}" for k in _TIMING_KEYS),
        _wall100(loaded=True),
    ),
    Scenario(
        "paced",
        "the default run: the paced world, five processes",
        120.0,
        6.0,
        tuple(f"paced_{k}" for k in PACED),
        _paced(frozen=False),
    ),
    Scenario(
        "paced_frozen",
        "the paced world, every node frozen 50 ms every 5 s (a host that stalls)",
        60.0,
        9.0,
        (*(f"paced_frozen_{k}" for k in PACED), "paced_frozen_injected"),
        _paced(frozen=True),
    ),
    Scenario(
        "wall1k_single",
        "wall clock 1 kHz, one process",
        20.0,
        3.0,
        (
            "wall1k_single_rate_hz",
            "wall1k_single_jitter_p99_ms",
            "wall1k_single_missed",
            "wall1k_single_missed_pct",
            "wall1k_missed_pct",
        ),
        _wall1k(single=True),
    ),
    Scenario(
        "wall1k_multi",
        "wall clock 1 kHz, five processes",
        20.0,
        3.0,
        ("wall1k_multi_rate_hz", "wall1k_multi_jitter_p99_ms", "wall1k_multi_missed", "wall1k_multi_missed_pct"),
        _wall1k(single=False),
    ),
    Scenario(
        "lockstep_multi",
        "sim-time lockstep, five processes",
        60.0,
        20.0,  # 2-3 s of wall clock: 3 s was 0.3 s, mostly the start
        ("lockstep_multi_tracking_rms_rad", "lockstep_rtf_multi"),
        _lockstep(single=False),
    ),
    Scenario(
        "lockstep_single",
        "sim-time lockstep, one process",
        60.0,
        20.0,  # 2-3 s of wall clock: 3 s was 0.3 s, mostly the start
        ("lockstep_single_tracking_rms_rad", "lockstep_rtf_single"),
        _lockstep(single=True),
    ),
    Scenario(
        "hop",
        "two-process rclpy round trips (the lockstep bound); a 1 kHz message's CPU in one process",
        10.0,
        2.0,
        ("hop_round_trips_per_s", "hop_limit_rtf", "lockstep_rtf_vs_hop_limit", "hop_message_cpu_us"),
        _hop,
    ),
    Scenario(
        "core",
        "in-process loop and batch (no ROS)",
        10.0,
        2.0,
        (
            "core_steps_per_s",
            "core_steps_per_s_panda",
            "batch_size",
            "batch_sim_s_per_s",
            "batch_best_tracking_rms_rad",
        ),
        _core,
    ),
)
SCENARIOS += (
    Scenario("campaign", "campaign: runs/s on 1 and 2 workers, Ray's overhead", 5.0, 1.0, CAMPAIGN_KEYS, _campaign),
    Scenario("loop_floor", "in-process loop against its MuJoCo calls", 10.0, 2.0, LOOP_FLOOR_KEYS, _loop_floor),
    Scenario(
        "franka",
        "the Panda through libfranka on the stand-in Franka, 1 kHz on its clock: run --hardware",
        60.0,
        6.0,
        franka_bench.FIGURES,
        lambda run: franka_bench.franka_run(run.out, run.duration_s),
    ),
    Scenario(
        "camera",
        "camera frames, no ROS: render, detect, solve at 640×480, one joint and the Panda (each for the duration)",
        10.0,
        2.0,
        camera_bench.KEYS,
        lambda run: camera_bench.camera_figures(run.duration_s),
    ),
)
_DECLARED = {key for scenario in SCENARIOS for key in scenario.keys}
assert all(target.key in _DECLARED for target in TARGETS), "a target names a key no scenario measures"


def bench(
    out_dir: Path, *, quick: bool = False, soak_s: float | None = None, progress: Callable[[str], None] = print
) -> dict[str, Any]:
    out_dir.mkdir(parents=True, exist_ok=True)
    params = cfg.load_stack()
    figures: dict[str, Any] = {
        "quick": quick,
        "machine": f"{os.cpu_count()} cores, {platform.platform()}",
        "python": platform.python_version(),
    }
    for scenario in SCENARIOS:
        duration_s = scenario.quick_duration_s if quick else scenario.duration_s
        if scenario.name == "soak" and soak_s is not None:
            duration_s = soak_s
        figures[f"{scenario.name}_duration_s"] = duration_s
        progress(f"{scenario.text}, {duration_s:g} s")
        measured = scenario.measure(Run(params, out_dir / scenario.name, duration_s, quick, dict(figures)))
        undeclared = set(measured) - set(scenario.keys) - {k for k in measured if k.endswith("_failure")}
        assert not undeclared, f"{scenario.name} measured undeclared keys {sorted(undeclared)}"
        figures.update({key: measured.get(key) for key in scenario.keys})  # None (null): not measured
        figures.update({k: v for k, v in measured.items() if k.endswith("_failure")})
    (out_dir / "bench.json").write_text(json.dumps(report.json_safe(figures), indent=2, sort_keys=True) + "\n")
    (out_dir / "bench.md").write_text(render_markdown(figures, [(s.name, f"{s.name}_duration_s") for s in SCENARIOS]))
    return figures
