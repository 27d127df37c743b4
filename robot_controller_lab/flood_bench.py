"""A foreign publisher (a process the run did not start, so outside its DDS
partition: see ``ros.partition``) floods one loop topic at 5 kHz for 5 s in
the middle of a wall-clock run of the default stack: how far does the arm get
from the reference in force during the flood? (The goal: within 0.02 rad.)

    python -m robot_controller_lab.flood_bench --out DIR

Writes ``flood.json`` and ``flood.md`` in DIR, one run per case below.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import rclpy
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from robot_controller import parameters as cfg
from robot_controller.ros import partition as dds_partition
from robot_controller.runner import launcher, plan
from robot_controller.runner.options import RunOptions
from robot_controller.scoring import report, scored_run

FLOOD_AT_S, FLOOD_S, RATE_HZ, RUN_S = 5.0, 5.0, 5000.0, 14.0
GOAL_RAD = 0.02


def _empty_reading(_: float) -> JointState:
    return JointState()


def _wrong_reading(now_s: float) -> JointState:
    msg = JointState(name=["joint1"], position=[0.3], velocity=[0.0])
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(now_s * 1e9), 1_000_000_000)
    return msg


def _zero_command(_: float) -> Float64MultiArray:
    return Float64MultiArray(data=[0.0])


#: name → (topic, message type, message at time s, what it is)
CASES: dict[str, tuple[str, type, Callable[[float], Any], str]] = {
    "joint_states_empty": ("/joint_states", JointState, _empty_reading, "empty readings (malformed, dropped)"),
    "joint_states_wrong": ("/joint_states", JointState, _wrong_reading, "plausible wrong readings (0.3 rad, now)"),
    "joint_commands_zero": ("/joint_commands", Float64MultiArray, _zero_command, "zero torque commands"),
}


class Flood:
    """A launcher watcher: from ``FLOOD_AT_S``, a process of its own publishes
    for ``FLOOD_S`` at ``RATE_HZ`` (never rclpy in the launcher itself: it
    forks the nodes from its own image)."""

    def __init__(self, case: str) -> None:
        self.case = case
        self.process: subprocess.Popen | None = None
        self.report: dict[str, float] = {}

    def __call__(self, elapsed_s: float, pids: dict[str, int]) -> None:
        if self.process is None and elapsed_s >= FLOOD_AT_S:
            # Foreign: whatever this process's environment says, not with the run's DDS profile.
            env = {k: v for k, v in os.environ.items() if k != dds_partition.PROFILES_ENV}
            self.process = subprocess.Popen(
                [sys.executable, "-m", "robot_controller_lab.flood_bench", "--publish", self.case],
                stdout=subprocess.PIPE,
                text=True,
                env=env,
            )

    def finish(self) -> dict[str, float]:
        if self.process is not None:
            out = self.process.communicate(timeout=60)[0]
            self.report = json.loads(out.strip().splitlines()[-1]) if out.strip() else {}
        return self.report


def publish(case: str) -> None:
    """The flooding process: publish, then print when it started and ended (system time) and how many."""
    topic, msg_type, make, _ = CASES[case]
    rclpy.init()
    node = Node("flooder")
    publisher = node.create_publisher(msg_type, topic, 10)
    time.sleep(0.5)  # discovery
    started_s = time.time()
    period, next_s, sent = 1.0 / RATE_HZ, time.monotonic(), 0
    while time.time() - started_s < FLOOD_S:
        publisher.publish(make(time.time()))
        sent += 1
        next_s += period
        delay = next_s - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    print(json.dumps({"started_s": started_s, "ended_s": time.time(), "sent": sent}), flush=True)
    node.destroy_node()
    rclpy.try_shutdown()


def run_case(case: str, out: Path) -> dict[str, Any]:
    flood = Flood(case)
    checked = plan.check(cfg.load_stack(), RunOptions(RUN_S))
    result = launcher.launch(checked, out, watcher=flood)
    sent = flood.finish()
    result.raise_if_interrupted()
    started_s, ended_s = sent.get("started_s", float("nan")), sent.get("ended_s", float("nan"))
    entry: dict[str, Any] = {
        "case": case,
        "topic": CASES[case][0],
        "what": CASES[case][3],
        "exit_code": result.exit_code,
        "sent": sent.get("sent", 0),
        "rate_hz": sent.get("sent", 0) / (ended_s - started_s),
    }
    if not scored_run.has_ticks(result):
        return entry | {"failure": result.failure or "no recording"}
    scored = scored_run.score_launched(checked, result)
    recording, values = scored.recording, scored.metrics
    during = report.tracking_on_sim_timeline(recording, started_s, ended_s)
    entry.update(
        {"tracking_max_during_rad": during["tracking_max_rad"], "tracking_rms_during_rad": during["tracking_rms_rad"]}
    )
    entry.update({k: values.get(k) for k in ("tracking_max_rad", "watchdog_ticks", "saturated_ticks")})
    return entry


def write(out: Path, entries: list[dict[str, Any]]) -> None:
    (out / "flood.json").write_text(json.dumps(report.json_safe(entries), indent=2) + "\n")
    rows = [
        "| topic | flood | sent (rate) | tracking max during [rad] | watchdog ticks | saturated ticks |",
        "|---|---|---|---|---|---|",
    ]
    for e in entries:
        during = e.get("tracking_max_during_rad")
        rows.append(
            f"| `{e['topic']}` | {e['what']} | {e['sent']} ({e['rate_hz']:.0f} Hz) | "
            f"{'–' if during is None else f'{during:.4f}'} | {e.get('watchdog_ticks')} | "
            f"{e.get('saturated_ticks')} |"
        )
    (out / "flood.md").write_text(
        f"# A foreign publisher floods a loop topic\n\nDefault preset, wall clock; {RATE_HZ:g} Hz for "
        f"{FLOOD_S:g} s from {FLOOD_AT_S:g} s. Goal: tracking within {GOAL_RAD} rad during the flood.\n\n"
        + "\n".join(rows)
        + "\n"
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m robot_controller_lab.flood_bench")
    parser.add_argument("--out", type=Path, default=Path("runs/flood"))
    parser.add_argument("--case", choices=sorted(CASES), action="append", help="default: every case")
    parser.add_argument("--publish", choices=sorted(CASES), help=argparse.SUPPRESS)  # the flooding process
    args = parser.parse_args(argv)
    if args.publish:
        publish(args.publish)
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    entries = [run_case(case, args.out / case) for case in (args.case or CASES)]
    write(args.out, entries)
    print((args.out / "flood.md").read_text())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
