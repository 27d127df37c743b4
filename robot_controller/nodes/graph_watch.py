"""graph_watch: the observer of a launcher of part of the graph (``run --nodes``). It prints the root
namespace's node names as ``@graph {"nodes": [...]}`` on every change and every ``REPORT_PERIOD_S``;
no gate waits for it. The graph is not partitioned: a split run wants a domain of its own."""

from __future__ import annotations

import argparse
import json
import time

import rclpy
from rclpy.node import Node

from robot_controller.ros.process import own_context

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
    context, stop = own_context()
    node = Node(NODE_NAME, context=context)
    last: list[str] | None = None
    next_report = 0.0
    try:
        while not stop.wait(POLL_S):
            in_root = {name for name, namespace in node.get_node_names_and_namespaces() if namespace == "/"}
            names = sorted(in_root - {NODE_NAME})
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
