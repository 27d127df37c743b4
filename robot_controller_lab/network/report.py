"""The network bench's report: ``network.json`` (every figure) and ``network.md`` (the table)."""

from __future__ import annotations

from typing import Any

from robot_controller_lab.network import conditions as cond


def document(entries: list[dict[str, Any]], quick: bool, started: str) -> dict[str, Any]:
    deviations = [e.get("band_deviation_rad") for e in entries if e.get("band_deviation_rad") is not None]
    return {
        "command": "robot-controller network" + (" --quick" if quick else ""),
        "date": started,
        "goal_band_deviation_rad": cond.GOAL_DEVIATION_RAD,
        "worst_band_deviation_rad": max(deviations) if deviations else None,
        "all_within_goal": bool(entries) and all(cond.within_goal(e) for e in entries),
        "runs": entries,
    }


def _num(value: Any, fmt: str) -> str:
    return "–" if value is None else fmt.format(value)


def reactions(entry: dict[str, Any]) -> str:
    fired = [f"{k.removesuffix('_ticks')} {entry[k]}" for k in cond.REACTIONS if entry.get(k)]
    if entry.get("brakes_engaged"):
        fired.append("brakes")
    return ", ".join(fired) or "none"


def lost(entry: dict[str, Any]) -> str:
    messages = entry.get("messages") or {}
    parts = [f"{t} {m['lost']}" for t, m in messages.items() if m.get("lost")]
    return ", ".join(parts) or "0"


def one_line(entry: dict[str, Any]) -> str:
    return (
        f"  {entry['split']} {entry['condition']}: rms {_num(entry.get('tracking_rms_rad'), '{:.4f}')} rad, "
        f"band {_num(entry.get('band_deviation_rad'), '{:.4f}')} rad, reactions: {reactions(entry)}, "
        f"exit {entry.get('robot_exit')}/{entry.get('control_exit')}"
        + (f" ({entry['failure']})" if "failure" in entry else "")
    )


def render(entries: list[dict[str, Any]], quick: bool, started: str) -> str:
    doc = document(entries, quick, started)
    lines = [
        "# Network bench: the loop split over two hosts",
        "",
        f"`{doc['command']}`, {started}. Two network namespaces joined by a veth pair (robot host 10.203.0.1: "
        "simulator, motor, sensor and the recorder, plus the controller when the planner alone is remote; control "
        "host 10.203.0.2: the rest), the reference scenario (one joint, sine 1 rad at 0.5 Hz, default controller, "
        "wall clock), `run --nodes/--peers/--run-id` in each. Loss: nftables drops that share of the packets "
        "arriving on each end; cap: tbf on each end; cut: the link down "
        f"{cond.CUT_AT_S:g} s after the loop closes. Band: how far the TRUE angle went outside the range the "
        "reference sweeps (from the cut, else after the 2 s warm-up). Re-acquired: back within 2 mrad of the plan "
        "for 0.1 s, after the link returned. Reactions: ticks in each controller state, and whether the brakes "
        "engaged. Lost: messages the robot host's nodes published that its recorder lacks. Exit: robot/control "
        "launcher.",
        "",
        f"**Worst band deviation: {_num(doc['worst_band_deviation_rad'], '{:.4f}')} rad** "
        f"(goal ≤ {cond.GOAL_DEVIATION_RAD:g} rad in every run).",
        "",
        "| split | condition | RMS [mrad] | max [mrad] | band [rad] | re-acquired [s] | reactions | lost | "
        "kbit/s robot→control / back | exit |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    texts = {c.name: c.text for c in cond.CONDITIONS}
    for e in entries:
        rms, peak = e.get("tracking_rms_rad"), e.get("tracking_max_rad")
        lines.append(
            f"| {e['split']} | {texts.get(e['condition'], e['condition'])} | "
            f"{_num(None if rms is None else rms * 1e3, '{:.2f}')} | "
            f"{_num(None if peak is None else peak * 1e3, '{:.1f}')} | "
            f"{_num(e.get('band_deviation_rad'), '{:.4f}')} | {_num(e.get('reacquire_s'), '{:.2f}')} | "
            f"{reactions(e)} | {lost(e)} | "
            f"{_num(e.get('kbit_s_robot_to_control'), '{:.0f}')} / "
            f"{_num(e.get('kbit_s_control_to_robot'), '{:.0f}')} | "
            f"{e.get('robot_exit')}/{e.get('control_exit')}" + (f" {e['failure']}" if "failure" in e else "") + " |"
        )
    return "\n".join(lines) + "\n"
