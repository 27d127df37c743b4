"""What the bench is measured against (``TARGETS``) and ``bench.md``, written
from the same figures as ``bench.json``."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


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
    Target("paced_watchdog_ticks", 0, True, "the default run (paced world, 120 s): the watchdog never fires"),
    Target("paced_late_efforts", 2, True, "… at most 2 efforts later than their tick (the nodes' own misses)"),
    Target("paced_frozen_watchdog_ticks", 0, True, "paced, every node frozen 50 ms every 5 s: no watchdog tick"),
    Target("paced_frozen_stopped_ticks", 0, True, "… no stopped tick"),
    Target("paced_frozen_tracking_max_rad", 0.006, True, "… tracking error never over 6 mrad"),
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
    Target("core_steps_per_s", 10_000.0, False, "in-process loop, one joint: ≥ 10,000 control steps per wall s"),
    Target("core_steps_per_s_panda", 1_000.0, False, "in-process loop, the 7-joint Panda: ≥ 1,000 steps per wall s"),
    Target("campaign_scaling_2w", 1.8, False, "campaign: 2 local workers ≥ 1.8× the runs/s of 1"),
    Target("loop_floor_panda_loop_vs_floor", 2.0, True, "in-process loop, Panda: ≤ 2× its MuJoCo calls' time"),
    Target("franka_ok", 1.0, False, "Panda on the stand-in Franka (run --hardware): the run ok"),
    Target("franka_success_rate", 0.999, False, "… the commands the robot took in time ≥ 0.999 over the run"),
    Target("franka_tick_p99_ms", 1.0, True, "… a tick's own time p99 within the robot's 1 ms"),
    Target("franka_tracking_rms_rad", 0.002, True, "… worst joint within 2 mrad RMS after the start"),
    Target("loop_floor_panda_loop_vs_physics", 2.0, True, "in-process loop, Panda: ≤ 2× the world's physics steps"),
    Target("loop_floor_one_dof_loop_vs_physics", 3.0, True, "in-process loop, one joint: ≤ 3× its physics steps"),
)


def render_markdown(figures: dict[str, Any], durations: list[tuple[str, str]]) -> str:
    """``bench.md`` from the same figures as ``bench.json``; ``durations``: (scenario, key of its duration)."""

    def fmt(value: Any) -> str:
        if isinstance(value, float):
            return f"{value:.4g}"
        return str(value)

    lines = [
        f"# robot-controller bench{' (quick)' if figures['quick'] else ''}",
        "",
        f"Machine: {figures['machine']}, Python {figures['python']}. Durations: "
        + ", ".join(f"{name} {figures[key]:g} s" for name, key in durations)
        + ".",
        "",
        "## Targets",
        "",
        "| target | figure | met? |",
        "|---|---|---|",
    ]
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
