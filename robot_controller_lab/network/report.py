"""The network bench's report: ``network.json`` (every figure) and ``network.md`` (the table)."""

from __future__ import annotations

from typing import Any

from robot_controller_lab.network import conditions as cond


def document(entries: list[dict[str, Any]], quick: bool, started: str) -> dict[str, Any]:
    """Every figure, and each case's verdict: it passed when the loop ran and kept its band (``cond.passed``)."""
    ran = [e for e in entries if cond.not_run(e) is None]
    deviations = [e.get("band_deviation_rad") for e in ran if e.get("band_deviation_rad") is not None]
    return {
        "command": "robot-controller network" + (" --quick" if quick else ""),
        "date": started,
        "goal_band_deviation_rad": cond.GOAL_DEVIATION_RAD,
        "worst_band_deviation_rad": max(deviations) if deviations else None,  #: of the cases where the loop ran
        "passed": sum(cond.passed(e) for e in entries),
        "all_passed": bool(entries) and all(cond.passed(e) for e in entries),
        "runs": [e | {"passed": cond.passed(e), "not_run": cond.not_run(e)} for e in entries],
    }


def verdict(entry: dict[str, Any]) -> str:
    why = cond.not_run(entry)
    if why is not None:
        return f"no: the loop did not run ({why})"
    return "yes" if cond.within_goal(entry) else "no: out of its band"


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
        f"exit {entry.get('robot_exit')}/{entry.get('control_exit')}, passed: {verdict(entry)}"
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
        "launcher. Passed: the loop ran (both launchers exit 0, the plan reached the robot host, at least "
        f"{cond.RAN_SHARE:.0%} of the controller's ticks recorded, brakes off at least {cond.RAN_SHARE:.0%} of the "
        f"scored time) and kept the TRUE angle within {cond.GOAL_DEVIATION_RAD:g} rad of its band.",
        "",
        f"**{doc['passed']} of {len(entries)} cases passed**; worst band deviation where the loop ran: "
        f"{_num(doc['worst_band_deviation_rad'], '{:.4f}')} rad (goal ≤ {cond.GOAL_DEVIATION_RAD:g} rad).",
        "",
        "| split | condition | RMS [mrad] | max [mrad] | band [rad] | re-acquired [s] | reactions | lost | "
        "kbit/s robot→control / back | exit | passed |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
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
            f"{e.get('robot_exit')}/{e.get('control_exit')}"
            + (f" {e['failure']}" if "failure" in e else "")
            + f" | {verdict(e)} |"
        )
    return "\n".join(lines) + "\n"
