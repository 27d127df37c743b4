"""graph_watch: the observer of a launcher of part of the graph (``run --nodes``). It prints the root
namespace's node names as ``@graph {"nodes": [...]}`` on every change and every ``REPORT_PERIOD_S``;
no gate waits for it. The graph is not partitioned: a split run wants a domain of its own.

With ``--ask LIMIT_S`` (the recording launcher's) it measures the other launchers' clocks (``core.clock_offset``)
in the run's partition every ``POLL_S``, reported every ``REPORT_PERIOD_S``; the others' answer with two stamps."""

from __future__ import annotations

import argparse
import contextlib
import json
import socket
import time
from collections import deque

import rclpy
from rclpy.node import Node
from std_msgs.msg import String

from robot_controller.blocks import spec
from robot_controller.core import clock_offset
from robot_controller.ros.process import make_executor, own_context

GRAPH_PREFIX = "@graph "
CLOCK_PREFIX = "@clock "
NODE_NAME = "graph_watch"
POLL_S = 0.1
REPORT_PERIOD_S = 1.0
REQUEST_TOPIC, REPLY_TOPIC = spec.CLOCK_PROBE_REQUEST.topic, spec.CLOCK_PROBE_REPLY.topic  # in the run's partition
PROBE_WINDOW, PROBE_MIN_SAMPLES = 30, 8  #: an estimate takes the latest 30 exchanges (3 s), once it has 8


def report_line(nodes: list[str]) -> str:
    return GRAPH_PREFIX + json.dumps({"nodes": sorted(nodes)})


def parse_line(line: str) -> list[str] | None:
    """The node names a ``report_line`` carries, or None for any other line."""
    if not line.startswith(GRAPH_PREFIX):
        return None
    try:
        return list(json.loads(line[len(GRAPH_PREFIX) :])["nodes"])
    except (ValueError, KeyError, TypeError):
        return None


class ClockProbe:
    """One side of the clock exchange: the asker's stamps t1, t4 (``limit_s`` given), the answerer's t2, t3."""

    def __init__(self, node: Node, limit_s: float | None, here: str) -> None:
        self.limit_s, self.here = limit_s, here
        self.exchanges: dict[str, deque[tuple[float, ...]]] = {}  #: per other launcher, stamps from t1 (s)
        topics, answer = (REQUEST_TOPIC, REPLY_TOPIC), (self.on_request if limit_s is None else self.on_reply)
        self.out = node.create_publisher(String, topics[limit_s is None], 10)
        node.create_subscription(String, topics[limit_s is not None], answer, 10)

    def ask(self) -> None:
        self.out.publish(String(data=json.dumps({"t1_ns": time.time_ns()})))

    def on_request(self, msg: String) -> None:
        t2 = time.time_ns()
        with contextlib.suppress(ValueError, KeyError, TypeError):
            reply = {"t1_ns": int(json.loads(msg.data)["t1_ns"]), "t2_ns": t2, "peer": self.here}
            self.out.publish(String(data=json.dumps(reply | {"t3_ns": time.time_ns()})))

    def on_reply(self, msg: String) -> None:
        t4 = time.time_ns()
        with contextlib.suppress(ValueError, KeyError, TypeError):
            got = json.loads(msg.data)
            stamps = tuple((t - int(got["t1_ns"])) * 1e-9 for t in (int(got["t1_ns"]), got["t2_ns"], got["t3_ns"], t4))
            self.exchanges.setdefault(str(got["peer"]), deque(maxlen=PROBE_WINDOW)).append(stamps)

    def report(self) -> None:
        """``@clock {"peer", "offset_ms", "round_trip_ms", "apart"}`` per other launcher; apart: the refusal or None."""
        for peer, exchanges in self.exchanges.items():
            if len(exchanges) >= PROBE_MIN_SAMPLES:
                found = clock_offset.estimate(list(exchanges))
                offset_ms, trip_ms = found.offset_s * 1e3, found.round_trip_s * 1e3
                apart = (
                    f"the clock of the other launcher ({peer}) is {offset_ms:+.1f} ms from this one's ({self.here}), "
                    f"round trip {trip_ms:.1f} ms: past {self.limit_s * 1e3:g} ms, half the drive's max_command_age_s;"
                    " synchronise the hosts' clocks (chrony, NTP)"
                )
                fields = {"peer": peer, "offset_ms": offset_ms, "round_trip_ms": trip_ms}
                fields["apart"] = apart if found.surely_beyond(self.limit_s) else None
                print(CLOCK_PREFIX + json.dumps(fields), flush=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog=NODE_NAME)
    parser.add_argument("--ask", type=float, metavar="LIMIT_S", help="measure the other launchers' clocks")
    parser.add_argument("--here", default="", help="this launcher's nodes, to name its clock")
    args = parser.parse_args(None if argv is None else argv[1:])
    context, stop = own_context()
    node = Node(NODE_NAME, context=context)
    probe = ClockProbe(node, args.ask, f"{socket.gethostname()}: {args.here}")
    last: list[str] | None = None
    next_report = 0.0

    def poll() -> None:
        nonlocal last, next_report
        if args.ask is not None:
            probe.ask()
        in_root = {name for name, namespace in node.get_node_names_and_namespaces() if namespace == "/"}
        names, now = sorted(in_root - {NODE_NAME}), time.monotonic()
        if names != last or now >= next_report:
            print(report_line(names), flush=True)
            if now >= next_report:
                probe.report()
            last, next_report = names, now + REPORT_PERIOD_S

    node.create_timer(POLL_S, poll)
    executor = make_executor(context)
    executor.add_node(node)
    try:
        while not stop.is_set():
            executor.spin_once(timeout_sec=POLL_S)
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
