"""``robot-controller network``: the reference scenario split over two network
namespaces (``netns``), under each condition of ``conditions``: two
launchers, ``run --nodes … --peers … --run-id …``, one in each host; the
robot host's records and scores. ``network.json`` and ``network.md`` in ``--out``."""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path
from typing import Any

import yaml

from robot_controller_lab.network import conditions as cond
from robot_controller_lab.network import netns
from robot_controller_lab.network import report as net_report

LOOP_LINE = "control loop running"
WAIT_S = 60.0  #: each launcher's --wait for the whole graph


def launcher_argv(nodes: tuple[str, ...], peer: str, run_id: str, out: Path, duration_s: float, config: Path | None):
    argv = [sys.executable, "-m", "robot_controller.cli", "run", "--nodes", ",".join(nodes), "--peers", peer]
    argv += ["--run-id", run_id, "--out", str(out), "--duration", f"{duration_s:g}", "--wait", f"{WAIT_S:g}"]
    return argv + (["--config", str(config)] if config is not None else [])


def _env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("FASTRTPS_DEFAULT_PROFILES_FILE", "ROS_STATIC_PEERS")}
    env["ROBOT_CONTROLLER_AFFINITY"] = env.get("ROBOT_CONTROLLER_AFFINITY", "1")
    return env


def _wait_line(log: Path, text: str, process, timeout_s: float) -> float | None:
    """When ``text`` appears in ``log`` (monotonic time), or None if the process ends or time runs out first."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if log.exists() and text in log.read_text(errors="replace"):
            return time.monotonic()
        if process.poll() is not None:
            return None
        time.sleep(0.05)
    return None


def run_one(net: netns.Link, split: cond.Split, condition: cond.Condition, out: Path, quick: bool) -> dict[str, Any]:
    out.mkdir(parents=True, exist_ok=True)
    duration = cond.duration_s(condition, quick)
    config = None
    if (overlay := condition.config()) is not None:
        config = out / "condition.yaml"
        config.write_text(yaml.safe_dump(overlay))
    if condition.loss_pct:
        net.set_loss(condition.loss_pct)
    if condition.rate_kbit:
        net.set_rate(condition.rate_kbit, condition.burst_bytes, condition.queue_ms)
    run_id = f"network-{os.getpid()}-{split.name}-{condition.name}"
    before = net.counters()
    started = time.monotonic()
    robot_log, control_log = out / "robot.log", out / "control.log"
    robot = net.spawn(
        net.robot,
        launcher_argv(split.robot_nodes, net.control.address, run_id, out / "robot", duration, config),
        env=_env(),
        log=robot_log,
    )
    control = net.spawn(
        net.control,
        launcher_argv(split.control_nodes, net.robot.address, run_id, out / "control", duration, config),
        env=_env(),
        log=control_log,
    )
    cut = None
    if condition.cut_s:
        closed = _wait_line(robot_log, LOOP_LINE, robot, WAIT_S + 30.0)
        if closed is not None:
            time.sleep(max(0.0, closed + cond.CUT_AT_S - time.monotonic()))
            cut = net.cut(condition.cut_s)
    robot_code = _wait(robot, duration + WAIT_S + 60.0)
    control_code = _wait(control, 45.0)
    after = net.counters()
    seconds = time.monotonic() - started
    dropped = net.dropped() if condition.loss_pct else None
    net.clear()
    entry: dict[str, Any] = {
        "split": split.name,
        "condition": condition.name,
        "robot_exit": robot_code,
        "control_exit": control_code,
        "duration_s": duration,
        "cut_s": condition.cut_s,
        "kbit_s_robot_to_control": (after["tx_bytes"] - before["tx_bytes"]) * 8e-3 / seconds,
        "kbit_s_control_to_robot": (after["rx_bytes"] - before["rx_bytes"]) * 8e-3 / seconds,
    }
    if condition.loss_pct:
        entry["packets_dropped"] = dropped
    try:
        entry.update(cond.run_figures(out / "robot", split, condition, cut))
    except (OSError, ValueError, KeyError, IndexError) as exc:
        entry["failure"] = f"not scored: {exc}"
    return entry


def _wait(process, timeout_s: float) -> int | None:
    import signal
    import subprocess

    try:
        return process.wait(timeout=timeout_s)
    except subprocess.TimeoutExpired:
        process.send_signal(signal.SIGINT)
        try:
            return process.wait(timeout=20.0)
        except subprocess.TimeoutExpired:
            process.kill()
            return process.wait()


def network(out: Path, *, quick: bool = False, progress=print) -> list[dict[str, Any]]:
    out.mkdir(parents=True, exist_ok=True)
    entries: list[dict[str, Any]] = []
    plan = cond.runs(quick)
    started = time.strftime("%Y-%m-%d %H:%M")
    with netns.link() as net:
        if net.removed_leftovers:
            progress("removed namespaces left by an earlier bench: " + ", ".join(net.removed_leftovers))
        for k, (split, condition) in enumerate(plan, 1):
            progress(f"[network] {k}/{len(plan)} {split.name}: {condition.text}")
            entry = run_one(net, split, condition, out / split.name / condition.name, quick)
            entries.append(entry)
            progress(net_report.one_line(entry))
            (out / "network.json").write_text(json.dumps(net_report.document(entries, quick, started), indent=2))
    (out / "network.json").write_text(json.dumps(net_report.document(entries, quick, started), indent=2))
    (out / "network.md").write_text(net_report.render(entries, quick, started))
    return entries


def main(out: Path, *, quick: bool = False) -> int:
    """The verb: exit 0 when every run ran and scored, 1 if one did not, 2 if the machine cannot host the bench."""
    try:
        netns.check_machine()
    except netns.NetworkBenchUnavailable as exc:
        print(f"robot-controller network: {exc}", file=sys.stderr)
        return 2
    if (out / "network.json").exists():
        print(f"robot-controller network: --out {out}: holds an earlier bench; choose another", file=sys.stderr)
        return 2
    try:
        entries = network(out, quick=quick)
    except KeyboardInterrupt:
        print("robot-controller network: interrupted; namespaces and rules removed", file=sys.stderr)
        return 130
    except RuntimeError as exc:
        print(f"robot-controller network: {exc}", file=sys.stderr)
        return 1
    print((out / "network.md").read_text())
    return 0 if all("failure" not in e for e in entries) else 1
