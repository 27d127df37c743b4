"""What a run says at its end: a verdict (``ok`` or ``FAILED: why``), then the dozen figures a person reads
first, as ``(label, text)`` rows: tracking on the true angle in mrad (the worst joint named), peak effort
against its limit, rate and misses unless on ``--sim-time``, faults and stops when there were any, where the files are.
The same rows make the terminal's end of a run and ``summary.md``; every other figure stays in ``metrics.json``."""

from __future__ import annotations

import collections
import math
from collections.abc import Sequence
from typing import Any

from robot_controller.core.metrics import EFFORT_UNITS, WARMUP_S
from robot_controller.scoring.camera_figures import camera_line

Row = tuple[str, str]  #: (label, text)

#: Ticks spent in a fault or a stop (``{name}_ticks``), said when non-zero. ``reacquiring`` is not one:
#: every run starts by leading the arm from where it is onto its trajectory.
FAULT_TICKS = (
    "watchdog",
    "sensor_lost",
    "reference_lost",
    "stopped",
    "law_fault",
    "law_stopped",
    "late",
    "late_stopped",
)
#: How a stop's ticks are said, where its name alone would not say whose it was.
FAULT_NAMES = {"stopped": "e-stopped (asked for)"}
#: ``metrics.json``'s ``clock``, as a person says it.
CLOCKS = {"sim_lockstep": "on sim time (--sim-time)", "sim_paced": "in the paced world", "wall": "on the wall clock"}
#: The reference arm's targets (docs/compare.md), by figure: what ``step`` and ``compare`` mark when missed.
REFERENCE_ARM = "one_dof"
REFERENCE_TARGETS = {
    "tracking_rms_rad": 0.0015,
    "overshoot_pct": 2.0,
    "settling_time_s": 0.25,
    "peak_torque_nm": 10.0,
}
MISSED = "✗ misses its target"
#: rad, the tracking error the tutorial says its controller reaches ("~0.005 rad (0.5% of amplitude)")
TUTORIAL_CLAIM_RAD = 0.005


def verdict(failure: str | None) -> str:
    return "ok" if failure is None else f"FAILED: {failure}"


def run_rows(
    values: dict[str, Any], *, effort_limits: Sequence[float] | None = None, out: str | None = None
) -> list[Row]:
    """The rows of a run's end from ``metrics.json``'s keys (a sim-time run's ``timing.json``'s too), with the
    controller's ``torque_max`` per joint if known and the run's directory ``out`` as the user named it."""
    rows = [("run", _run_line(values)), ("tracking", tracking_line(values))]
    if start := start_line(values):
        rows.append(("start", start))
    if pushed := _pushed_line(values):
        rows.append(("pushes", pushed))
    if values.get("preset") == "tutorial" and finite(rms := values.get("tracking_rms_rad")):
        claim = f"the tutorial claims ~{TUTORIAL_CLAIM_RAD * 1e3:g} mrad; its controller as written tracks at "
        rows.append(("tutorial", claim + f"{rms * 1e3:.3g} mrad RMS"))
    if effort := effort_line(values, effort_limits, note=", start-up included"):
        rows.append(("peak effort", effort))
    if values.get("clock") in ("wall", "sim_paced") and finite(values.get("control_rate_hz")):
        rows.append(("rate", _rate_line(values)))
    if sensing := camera_line(values):
        rows.append(("sensing", sensing))
    rows += _trouble_rows(values)
    if out is not None:
        rows.append(("files", f"{out}/: summary.md, tracking.png, metrics.json, bag/"))
        rows.append(("all figures", f"robot-controller score {out} --all"))
    return rows


def step_rows(values: dict[str, Any], *, robot: str, effort_limits: Sequence[float] | None = None) -> list[Row]:
    """A step response's rows (``step``'s ``metrics.json``); on the reference arm, a figure over its target marked."""
    targets = REFERENCE_TARGETS if robot == REFERENCE_ARM else {}

    def judged(key: str, text: str, unit: str) -> str:
        value, target = values.get(key), targets.get(key)
        if target is None or (finite(value) and value <= target):
            return text
        return f"{text}  {MISSED} ≤ {target:g} {unit}"

    settling = values.get("settling_time_s")
    rows = [
        (
            "step",
            f"{values.get('amplitude_rad')} rad ({values.get('step_shaping')}), {robot}, seed {values.get('seed')}",
        ),
        ("overshoot", judged("overshoot_pct", f"{_num(values.get('overshoot_pct'), '.2f')} %", "%")),
        ("rise 10–90 %", f"{_num(values.get('rise_time_s'), '.3f')} s"),
        ("settling 2 %", judged("settling_time_s", "never" if not finite(settling) else f"{settling:.3f} s", "s")),
        ("steady state", f"{_num(_milli(values.get('steady_state_error_rad')), '.3g')} mrad from the target"),
    ]
    # The step's own peaks (from the step on), not the run's.
    peaks = values.get("peak_torque_nm_per_joint") if len(_joints(values)[0]) > 1 else [values.get("peak_torque_nm")]
    effort = effort_line(values, effort_limits, peaks) or "n/a"
    rows.append(("peak effort", judged("peak_torque_nm", effort, "N·m")))
    return rows + _trouble_rows(values)


#: ``compare.json``'s figures judged against the reference arm's targets, and how each is said.
COMPARE_TARGETS = {
    "sine_tracking_rms_rad": ("tracking_rms_rad", "sine RMS", 1e3, "mrad"),
    "step_overshoot_pct": ("overshoot_pct", "step overshoot", 1.0, "%"),
    "step_settling_time_s": ("settling_time_s", "step settling", 1.0, "s"),
    "step_peak_torque_nm": ("peak_torque_nm", "peak torque", 1.0, "N·m"),
}


def compare_missed(table: dict[str, dict[str, Any]], robot: str) -> list[str]:
    """Each contender's mean figure over its target (``compare.json``), one line each; none off the reference arm."""
    if robot != REFERENCE_ARM:
        return []
    missed = []
    for name, row in table.items():
        for key, (target_key, said, scale, unit) in COMPARE_TARGETS.items():
            mean, target = (row.get(key) or {}).get("mean"), REFERENCE_TARGETS[target_key]
            if key in row and not (finite(mean) and mean <= target):
                shown = "never settled" if not finite(mean) else f"{mean * scale:.3g} {unit}"
                missed.append(f"{MISSED}: {name}: {said} {shown} (target ≤ {target * scale:g} {unit})")
    return missed


def faults_rows(entries: Sequence[dict[str, Any]], failed: Sequence[str], goal: float) -> list[Row]:
    """The fault bench's rows (its cases: ``faults.json``'s ``cases``); ``failed``: a line per case that missed."""
    n = len(entries)
    deviations = [(e.get(f"max_deviation_{u}"), e["case"], u) for e in entries for u in ("rad", "m")]
    deviations = [d for d in deviations if finite(d[0])]
    rows = [("cases", f"{n}: {', '.join(dict.fromkeys(e['case'] for e in entries))}" if n <= 3 else str(n))]
    # Freezes strike the paced world unless --wall-clock; kills are respawned on the wall clock.
    worlds = collections.Counter(e.get("world", "wall clock") for e in entries)
    rows.append(("world", ", ".join(f"{world} ({_count(count, 'case')})" for world, count in worlds.items())))
    if deviations:
        worst, case, unit = max(deviations)
        milli = "mrad" if unit == "rad" else "mm"
        rows.append(("worst deviation", f"{worst * 1e3:.3g} {milli} ({case}), goal ≤ {goal * 1e3:g} {milli}"))
    rows.append(("brakes engaged", f"in {sum(bool(e.get('brake_engaged')) for e in entries)} of {n} cases"))
    back = [(e["reacquire_s"], e["case"]) for e in entries if finite(e.get("reacquire_s"))]
    if back:
        slowest, case = max(back)
        not_back = n - len(back)
        text = f"within {slowest:.2f} s of the fault's end ({case} the slowest)"
        rows.append(("re-acquired", text + (f"; not in {_count(not_back, 'case')}" if not_back else "")))
    shown = 5  # the rest are in faults.md
    rows += [("missed", line) for line in failed[:shown]]
    if len(failed) > shown:
        rows.append(("missed", f"{len(failed) - shown} more in faults.md"))
    return rows


def lines(verdict_line: str | None, rows: Sequence[Row]) -> list[str]:
    """The verdict, the rows with their labels aligned, and a FAILED verdict again last (None: the rows alone)."""
    width = max((len(label) for label, _ in rows), default=0) + 2
    body = [f"{label:<{width}}{text}" for label, text in rows]
    if verdict_line is None:
        return body
    return [verdict_line, *body, *([verdict_line] if verdict_line != "ok" else [])]


def markdown(verdict_line: str, rows: Sequence[Row], *, title: str, command: str, links: Sequence[str]) -> str:
    """``summary.md``: the verdict, the command that made the run, the rows, and relative links to ``links``."""
    lines = [f"# {title}", "", f"**{verdict_line}**", "", "```", command, "```", ""]
    lines += [f"- **{label}**: {text}" for label, text in rows if label not in ("files", "all figures")]
    lines += ["", " · ".join(f"[{name}]({name})" for name in links)]
    if "tracking.png" in links:
        lines += ["", "![tracking](tracking.png)"]
    return "\n".join(lines) + "\n"


def tracking_line(values: dict[str, Any]) -> str:
    """Tracking on the true angle, RMS and max, in mrad (mm for a prismatic joint); the worst joint named on a chain."""
    if not values.get("scored_samples", 1):
        return f"not scored: nothing after the {WARMUP_S:g} s start"
    names, units = _joints(values)
    rms = _per_joint(values, "tracking_rms", units)
    peak = _per_joint(values, "tracking_max", units)
    said = []
    for unit, milli in (("rad", "mrad"), ("m", "mm")):
        mine = [j for j, u in enumerate(units) if u == unit]
        if mine:
            worst_rms, worst_max = _worst(rms, mine), _worst(peak, mine)
            on_rms, on_max = (f" on {names[worst_rms]}", f" on {names[worst_max]}") if len(names) > 1 else ("", "")
            said.append(
                f"RMS {_num(_milli(rms[worst_rms]), '.3g')} {milli}{on_rms}, max {_num(_milli(peak[worst_max]), '.3g')}"
                f" {milli}{on_max}"
            )
    where = f": the worst of {len(names)} joints" if len(names) > 1 else ""
    return "; ".join(said) + f"{where} (true {'position' if 'm' in units else 'angle'}, after {WARMUP_S:g} s)"


def start_line(values: dict[str, Any]) -> str | None:
    """The start's transient, which the tracking line leaves out: its largest error, when it ended, the band."""
    names, units = _joints(values)
    peak = values.get("start_tracking_max_per_joint")
    if not peak or len(peak) != len(names) or not any(finite(p) for p in peak):
        return None
    worst = _worst(peak, None)
    milli = "mrad" if units[worst] == "rad" else "mm"
    on = f" on {names[worst]}" if len(names) > 1 else ""
    text = f"max {_num(_milli(peak[worst]), '.3g')} {milli}{on} in the first {WARMUP_S:g} s"
    if finite(ended := values.get("start_transient_end_s")) and values.get("scored_samples"):
        text += ", no worse than after it" + (f" from {ended:.2f} s" if ended > 0 else "")
    if finite(band := values.get("tracking_band_rad")):
        text += f" (band {band * 1e3:g} {milli})"
    return text


def _pushed_line(values: dict[str, Any]) -> str | None:
    """What the band judged where someone pushed the arm: the tracking without each push and the second after it."""
    names, units = _joints(values)
    peak = values.get("unpushed_max_per_joint")
    if not peak or len(peak) != len(names):
        return None
    worst = _worst(peak, None)
    milli = "mrad" if units[worst] == "rad" else "mm"
    figure = f"max {_num(_milli(peak[worst]), '.3g')} {milli}"
    return f"{figure} without each push and the 1 s after it (what the band judges)"


def effort_line(
    values: dict[str, Any],
    limits: Sequence[float] | None = None,
    peaks: Sequence[float] | None = None,
    note: str = "",
) -> str | None:
    """The peak effort against its limit; on a chain, of the joint nearest its limit. ``peaks``: each joint's
    (default ``peak_effort_per_joint``); ``note``: what it spans, said before the ticks saturated."""
    names, units = _joints(values)
    peaks = peaks or values.get("peak_effort_per_joint") or values.get("peak_torque_nm_per_joint")
    if not peaks or len(peaks) != len(names):
        peaks = [values.get("peak_torque_nm")] * len(names)
    if not any(finite(p) for p in peaks):
        return None
    limits = list(limits) if limits is not None and len(limits) == len(peaks) else None
    scale = limits if limits is not None else [1.0] * len(peaks)
    j = _worst([p / s if finite(p) and s > 0 else float("nan") for p, s in zip(peaks, scale, strict=True)], None)
    unit = EFFORT_UNITS.get(units[j], "N·m")
    text = f"{peaks[j]:.3g} {unit}"
    if limits is not None:
        text += f" of {limits[j]:g} {unit} ({100 * peaks[j] / limits[j]:.0f} %)"
    if len(names) > 1:
        text += f" on {names[j]}, the nearest its limit" if limits is not None else f" on {names[j]}"
    text += note
    if saturated := values.get("saturated_ticks"):
        text += f"; {_count(saturated, 'tick')} saturated"
    return text


def _run_line(values: dict[str, Any]) -> str:
    who = f"{values.get('robot', '?')}, preset {values.get('preset', '?')}, seed {values.get('seed', '?')}"
    clock = values.get("clock")
    text = f"{who}: {_num(values.get('duration_s'), 'g')} s {CLOCKS.get(clock, '')}".rstrip()
    if values.get("interrupted"):
        text += ", interrupted (what was recorded is scored)"
    if clock == "sim_lockstep" and finite(factor := values.get("real_time_factor")):
        text += f", {factor:.1f}× real time"
    return text


def _robot_rate_line(values: dict[str, Any]) -> str:
    """A robot's clock: its periods without a command by its own count, the commands it took, our time per tick
    against its period, and what the hypervisor took from this host meanwhile."""
    taken, low = _num(values.get("command_success_rate"), ".5f"), _num(values.get("command_success_rate_min"), ".2f")
    p50, p99, most = (_num(values.get(f"tick_compute_{k}_ms"), ".2f") for k in ("p50", "p99", "max"))
    text = (
        f"1 kHz by the robot's clock (recorded at {values['control_rate_hz']:.0f} Hz), "
        f"{_count(int(values.get('robot_missed_cycles', 0)), 'period')} missed by its count: it took {taken} "
        f"of the commands in time (its 100-command low {low}); our tick {p50} ms p50, {p99} p99, {most} max of its 1 ms"
    )
    if finite(steal := values.get("host_steal_pct")):
        text += f"; the hypervisor took {steal:.2f} % of this host"
    return text


def _rate_line(values: dict[str, Any]) -> str:
    if values.get("hardware"):
        return _robot_rate_line(values)
    text = f"{values['control_rate_hz']:.1f} Hz, {_count(values.get('missed_cycles', 0), 'missed cycle')}"
    if host_missed := values.get("missed_cycles_host"):
        text += f" ({host_missed} more the host made, not counted)"
    if values.get("clock") == "wall" and finite(values.get("jitter_p99_ms")):
        text += f", jitter p99 {values['jitter_p99_ms']:.2f} ms"
    if late := values.get("late_efforts"):
        text += f", {_count(late, 'late effort')} (the world waited for the loop)"
    if host_late := values.get("late_efforts_host"):
        text += f"; {_count(host_late, 'effort')} the host made late (not counted)"
    if stale := values.get("stale_efforts"):
        text += f"; {_count(stale, 'stale effort')} dropped (the world had moved on)"
    return text


def _trouble_rows(values: dict[str, Any]) -> list[Row]:
    """Faults and stops, host freezes, messages lost: only those that happened."""
    rows = []
    faults = [
        f"{FAULT_NAMES.get(name, name.replace('_', ' '))} {_count(n, 'tick')}"
        for name in FAULT_TICKS
        if (n := values.get(f"{name}_ticks"))
    ]
    if host_watchdog := values.get("watchdog_ticks_host"):  # said as the rate line says missed cycles
        if values.get("watchdog_ticks"):
            faults[0] += f" ({host_watchdog} more the host made, not counted)"
        else:
            faults.insert(0, f"watchdog: {_count(host_watchdog, 'tick')} the host made (not counted)")
    if faults:
        rows.append(("faults", ", ".join(faults)))
    if engagements := values.get("brake_engagements"):
        held_s = _num(values.get("braked_s"), ".2f")
        text = f"held the arm {_count(engagements, 'time')}, {held_s} s in all (not scored as tracking)"
        if estop := values.get("brake_engagements_estop"):
            text += f"; {estop} of them your e-stop's ({_num(values.get('braked_s_estop'), '.2f')} s)"
        rows.append(("brakes", text))
    if freezes := values.get("host_freezes"):
        longest, total = values.get("host_freeze_ms_max"), values.get("host_freeze_ms_total")
        text = f"{freezes}, the longest {_num(longest, '.0f')} ms, {_num(total, '.0f')} ms in all"
        rows.append(("host freezes", text + (" (the world paused)" if values.get("clock") == "sim_paced" else "")))
    lost = []
    if unrecorded := values.get("unrecorded_messages"):
        lost.append(f"{_count(unrecorded, 'published message')} missing from the bag")
    if malformed := values.get("malformed_messages"):
        lost.append(f"{_count(malformed, 'malformed message')} skipped")
    if lost:
        rows.append(("recording", ", ".join(lost)))
    return rows


def _joints(values: dict[str, Any]) -> tuple[list[str], list[str]]:
    names = list(values.get("joint_names") or ["joint"])
    units = list(values.get("joint_units") or ["rad"] * len(names))
    return names, units if len(units) == len(names) else ["rad"] * len(names)


def _per_joint(values: dict[str, Any], name: str, units: list[str]) -> list[Any]:
    """``{name}_per_joint``, or the headline figure of each joint's unit (a metrics.json without the lists)."""
    per_joint = values.get(f"{name}_per_joint")
    if per_joint and len(per_joint) == len(units):
        return list(per_joint)
    return [values.get(f"{name}_{unit}") for unit in units]


def _worst(figures: Sequence[Any], among: Sequence[int] | None) -> int:
    """The index of the largest finite figure of ``among`` (default all); the first if none is finite."""
    among = list(among if among is not None else range(len(figures)))
    candidates = [j for j in among if finite(figures[j])]
    return max(candidates, key=lambda j: figures[j]) if candidates else among[0]


def finite(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _milli(value: Any) -> Any:
    return value * 1e3 if finite(value) else value


def _num(value: Any, spec: str) -> str:
    return format(value, spec) if finite(value) else "n/a"


def _count(n: int, noun: str) -> str:
    return f"{n} {noun}{'' if n == 1 else 's'}"
