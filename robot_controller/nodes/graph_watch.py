"""graph_watch: an observer the launcher starts when it runs only part of the
graph (``run --nodes``): it reports, on its standard output, which nodes the
ROS graph shows, so the launcher can wait for the other side's nodes and
notice when they leave.

It creates no publisher or subscription of its own (it is nobody's audience:
the publication gates never wait for it) and only reads the graph, which
discovery fills in whatever the partition: the nodes of another run with the
same names, on the same domain, would be taken for this run's (a split run
wants a domain of its own, or at least no second split run beside it).

Output: ``@graph {"nodes": [...]}`` with the root namespace's node names,
sorted, whenever they change and at least every ``REPORT_PERIOD_S``.
"""

from __future__ import annotations

import argparse
import json
import signal
import threading
import time

import rclpy
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

GRAPH_PREFIX = "@graph "
NODE_NAME = "graph_watch"
POLL_S = 0.1
REPORT_PERIOD_S = 1.0


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


def main(argv: list[str] | None = None) -> int:
    argparse.ArgumentParser(prog=NODE_NAME).parse_args(None if argv is None else argv[1:])
    stop = threading.Event()
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    node = Node(NODE_NAME, context=context)
    last: list[str] | None = None
    next_report = 0.0
    try:
        while not stop.wait(POLL_S):
            names = sorted(
                {name for name, namespace in node.get_node_names_and_namespaces() if namespace == "/"} - {NODE_NAME}
            )
            now = time.monotonic()
            if names != last or now >= next_report:
                print(report_line(names), flush=True)
                last, next_report = names, now + REPORT_PERIOD_S
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
