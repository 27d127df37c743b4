"""``topic list | echo | hz``: ros2cli's ``ros2 topic`` verbs against any graph on the domain, printing what ros2cli
prints; a topic's type is the graph's, messages formatted field by field."""

from __future__ import annotations

import math
import queue
import threading
import time
from collections import deque
from typing import Any

from robot_controller.tools import graph
from robot_controller.tools.graph import ToolError

#: How long ``echo`` and ``hz`` wait for the topic to show in the graph.
TOPIC_WAIT_S = graph.DISCOVERY_TIMEOUT_S
#: ros2 topic hz's default window, in intervals between messages.
DEFAULT_WINDOW = 10000
REPORT_PERIOD_S = 1.0
ECHO_DEPTH = 100  # a reader that prints falls behind a 100 Hz topic now and then: keep what it has not printed
HZ_DEPTH = 100


@graph.command("topic list")
def topic_list(show_types: bool = False) -> int:
    """``ros2 topic list [-t]``: every topic on the domain, sorted; with its types in brackets."""
    with graph.open_graph("topic list") as g:
        topics = g.settled_topics()
    for name in sorted(topics):
        print(f"{name} [{', '.join(topics[name])}]" if show_types else name, flush=True)
    return 0


@graph.command("topic echo")
def topic_echo(topic: str, count: int | None = None, csv: bool = False) -> int:
    """``ros2 topic echo [--csv]``: ``count`` messages (None: until Ctrl-C) as YAML then ``---``, or CSV lines
    after a header line naming each column (which ros2's ``--csv`` does not write)."""
    if count is not None and count < 1:
        raise ToolError(f"count must be at least 1, got {count}")
    topic = graph.absolute(topic)
    with graph.open_graph("topic echo") as g:
        msg_type = _topic_class(g, topic)
        received: queue.SimpleQueue = queue.SimpleQueue()
        g.node.create_subscription(msg_type, topic, lambda msg: received.put(msg), _echo_qos(g, topic))
        printed = 0
        while count is None or printed < count:
            try:
                msg = received.get(timeout=0.1)  # a short wait: Ctrl-C is heard at once
            except queue.Empty:
                continue
            if csv:
                if printed == 0:  # the columns' names, from the first message's fields and sizes
                    print(csv_header(msg), flush=True)
                print(message_to_csv(msg), flush=True)
            else:
                print(message_to_yaml(msg), end="---\n", flush=True)
            printed += 1
    return 0


def _topic_class(g: graph.Graph, topic: str) -> type:
    """The message class of ``topic``, once it shows in the graph (within ``TOPIC_WAIT_S``)."""
    types = g.wait_for_topic(topic, TOPIC_WAIT_S)
    if len(types) > 1:
        raise ToolError(f"{topic}: carries more than one type ({', '.join(types)}); cannot tell which to read")
    try:
        return graph.message_class(types[0])
    except ToolError as exc:
        raise ToolError(f"{topic}: {exc}") from None


def _echo_qos(g: graph.Graph, topic: str) -> Any:
    """As ros2 topic echo chooses: reliable and transient-local only if every publisher is, so that the reader
    matches them all (a reliable reader misses best-effort writers)."""
    from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

    publishers = g.node.get_publishers_info_by_topic(topic)
    best_effort = any(p.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for p in publishers)
    latched = bool(publishers) and all(p.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publishers)
    return graph.qos(ECHO_DEPTH, best_effort=best_effort, latched=latched)


def message_to_plain(value: Any) -> Any:
    """A message as dicts (in field order), lists and Python scalars, as ros2cli sees it."""
    if hasattr(type(value), "get_fields_and_field_types"):  # a message
        return {name: message_to_plain(getattr(value, name)) for name in value.get_fields_and_field_types()}
    if isinstance(value, list | tuple):
        return [message_to_plain(v) for v in value]
    if isinstance(value, bytes | bytearray):
        return "".join(chr(c) for c in value)  # byte / char fields, as ros2cli shows them
    if hasattr(value, "tolist"):  # array.array, numpy arrays and numpy scalars
        return value.tolist()
    return value


def message_to_yaml(msg: Any) -> str:
    """``field: value`` lines, nested messages indented, sequences as ``- x`` items (ros2cli's layout)."""
    import yaml

    return yaml.safe_dump(
        message_to_plain(msg), default_flow_style=False, sort_keys=False, allow_unicode=True, width=float("inf")
    )


def message_to_csv(msg: Any) -> str:
    """The flattened values in field order, comma-separated (an empty sequence leaves an empty cell)."""

    def cell(value: Any) -> str:
        if isinstance(value, dict | list):
            return ",".join(cell(v) for v in (value.values() if isinstance(value, dict) else value))
        return str(value)

    return cell(message_to_plain(msg))


def csv_header(msg: Any) -> str:
    """The names of :func:`message_to_csv`'s columns for ``msg``: each field's path (``header.stamp.sec``), a
    sequence's items indexed (``position[0]``), an empty sequence its one empty column. A later message with longer
    sequences has more columns than its header names."""

    def names(value: Any, path: str) -> list[str]:
        if isinstance(value, dict):
            return [name for key, item in value.items() for name in names(item, f"{path}.{key}" if path else key)]
        if isinstance(value, list):
            return [name for k, item in enumerate(value) for name in names(item, f"{path}[{k}]")] or [path]
        return [path]

    return ",".join(names(message_to_plain(msg), ""))


class RateWindow:
    """Intervals between receptions over the last ``window`` of them: ros2 topic hz's statistics."""

    def __init__(self, window: int) -> None:
        self.intervals_ns: deque[int] = deque(maxlen=window)
        self.count = 0
        self._last_ns: int | None = None
        self._reported_count = 0
        self._lock = threading.Lock()

    def heard(self, stamp_ns: int) -> None:
        with self._lock:
            self.count += 1
            if self._last_ns is not None and stamp_ns >= self._last_ns:
                self.intervals_ns.append(stamp_ns - self._last_ns)
            self._last_ns = stamp_ns  # a clock that went back starts the intervals afresh

    def report(self) -> str | None:
        """ros2's two lines, or None when nothing new came since the last report."""
        with self._lock:
            if self.count == self._reported_count or not self.intervals_ns:
                return None
            self._reported_count = self.count
            times = list(self.intervals_ns)
        n = len(times)
        mean = sum(times) / n
        rate = 1e9 / mean if mean > 0 else 0.0
        std_dev = math.sqrt(sum((t - mean) ** 2 for t in times) / n)
        return (
            f"average rate: {rate:.3f}\n\tmin: {min(times) * 1e-9:.3f}s max: {max(times) * 1e-9:.3f}s "
            f"std dev: {std_dev * 1e-9:.5f}s window: {n}"
        )


@graph.command("topic hz")
def topic_hz(topic: str, window: int = DEFAULT_WINDOW, duration_s: float | None = None) -> int:
    """``ros2 topic hz [-w window]``: the rate over the last ``window`` intervals, every second, until Ctrl-C (exit
    0) or for ``duration_s`` (exit 1 if nothing came)."""
    if window < 1:
        raise ToolError(f"window must be at least 1, got {window}")
    if duration_s is not None and not duration_s > 0:
        raise ToolError(f"duration must be > 0 s, got {duration_s}")
    topic = graph.absolute(topic)
    with graph.open_graph("topic hz") as g:
        msg_type = _topic_class(g, topic)
        rate = RateWindow(window)

        def heard(_raw: bytes, info: dict) -> None:
            # DDS's reception time, when it gives one: what the topic did, not when the executor got to it.
            rate.heard(info.get("received_timestamp") or time.time_ns())

        # Best effort, as ros2 topic hz's sensor-data profile: matches every publisher and never holds one back.
        g.node.create_subscription(msg_type, topic, heard, graph.qos(HZ_DEPTH, best_effort=True), raw=True)
        end = None if duration_s is None else time.monotonic() + duration_s
        next_report = None
        while end is None or time.monotonic() < end:
            time.sleep(0.05)
            now = time.monotonic()
            if next_report is None:
                if rate.count:
                    next_report = now + REPORT_PERIOD_S
            elif now >= next_report:
                _print_report(rate)
                next_report += REPORT_PERIOD_S
                if next_report <= now:  # this process was held up: report a second from now
                    next_report = now + REPORT_PERIOD_S
    if duration_s is not None and rate.count == 0:
        raise ToolError(f"{topic}: no message in {duration_s:g} s")
    if duration_s is not None:
        _print_report(rate)  # what came since the last report
    return 0


def _print_report(rate: RateWindow) -> None:
    text = rate.report()
    if text is not None:
        print(text, flush=True)
