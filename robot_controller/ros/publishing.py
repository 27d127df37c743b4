"""Publishing that waits for its audience: a gate holds what a node publishes
until its consumer (and, when the run is recorded, the recorder) has matched,
so nothing the loop sends is lost to discovery; each gate counts what it sent."""

from __future__ import annotations

import copy
import json
import os
import time
from collections import deque
from pathlib import Path
from typing import Any

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import QoSProfile

from robot_controller.ros.qos import CONTROL_QOS

# Nodes that only watch (the recorder, a viewer) do not count as consumers.
RECORDER_NODE = "recorder"
VIEWER_NODE = "viewer"
OBSERVER_NODES = frozenset({RECORDER_NODE, VIEWER_NODE})

# Set by the launcher when a recorder runs: every publisher then waits for it too (the bag holds every message).
RECORDED_ENV = "ROBOT_CONTROLLER_RECORDED"
# Where each node writes, when it stops, how many messages it published per topic (checked against the bag).
COUNTS_DIR_ENV = "ROBOT_CONTROLLER_COUNTS_DIR"


def recorded() -> bool:
    return os.environ.get(RECORDED_ENV, "") == "1"


def run_folder() -> str:
    """The run's scratch folder (``COUNTS_DIR_ENV``), or "" for a node started without the launcher."""
    return os.environ.get(COUNTS_DIR_ENV, "")


def leave(file_name: str, text: str) -> None:
    """``text`` in the run's scratch folder, for the launcher (nothing without one; a failure loses only it)."""
    if run_folder():
        try:
            Path(run_folder(), file_name).write_text(text)
        except OSError:
            pass


# Discovery is two-sided: a writer can see a reader before the reader knows the writer, and the
# reader drops what arrives in between. A reader counts as matched once seen for this long.
MATCH_SETTLE_S = 0.25
MAX_HELD = 1000  # messages a gate holds at most (10 s of a 100 Hz topic)


class GatedPublisher:
    """Holds what is published until its audience (a consumer, and the recorder when the run is recorded)
    has matched, then publishes; counts what it published. ``consumer=False``: telemetry."""

    def __init__(
        self,
        node: Node,
        msg_type: Any,
        topic: str,
        *,
        world_waits: bool,
        consumer: bool = True,
        qos: QoSProfile = None,
        kept: bool = True,
    ) -> None:
        """``kept``: the recorder records the topic (a camera's raw frames it does not: the gate never waits for it,
        and its count is not checked against the bag)."""
        self.node, self.topic = node, topic
        self.publisher = node.create_publisher(msg_type, topic, qos or CONTROL_QOS)
        self.consumer = consumer
        self.kept = kept
        self.recorder = recorded() and kept
        self.open = not consumer and not self.recorder
        # Held until open: every message for telemetry and where the world waits (each is a tick, and the bag
        # must hold them all), only the newest for a wall-clock consumer (an old torque is worth nothing).
        self.pending: deque[Any] = deque(maxlen=MAX_HELD if not consumer or world_waits else 1)
        self.count = 0
        self.seen_since: float | None = None  # monotonic s the audience was first seen, while it stays
        self._poll = None
        if not self.open:
            self._poll = node.create_timer(0.05, self._check, clock=Clock(clock_type=ClockType.STEADY_TIME))

    def publish(self, msg: Any) -> None:
        if self.open:
            self.publisher.publish(msg)
            self.count += 1
        else:
            # For the poll timer to flush: publish() may run on a thread of the node's own (the simulator's pacing).
            self.pending.append(copy.deepcopy(msg))

    def audience_present(self) -> bool:
        """The audience in the graph by name, and as many readers matched (DDS matching honours the run's
        partition; the graph does not)."""
        names = [info.node_name for info in self.node.get_subscriptions_info_by_topic(self.topic)]
        if self.consumer and all(name in OBSERVER_NODES for name in names):
            return False
        if self.recorder and RECORDER_NODE not in names:
            return False
        return self.publisher.get_subscription_count() >= int(self.consumer) + int(self.recorder)

    def _check(self) -> None:
        if self.open:
            return
        if not self.audience_present():
            self.seen_since = None
            return
        now = time.monotonic()
        self.seen_since = self.seen_since or now
        if now - self.seen_since < MATCH_SETTLE_S:
            return
        self.open = True
        self.node.destroy_timer(self._poll)
        self.node.get_logger().debug(f"{self.topic}: audience matched, publishing")
        while self.pending:  # popleft, not iteration: another thread may still append
            self.publisher.publish(self.pending.popleft())
            self.count += 1


def write_publish_counts(node_name: str, gates: list[GatedPublisher]) -> None:
    """How many messages ``gates`` published, per topic, for the launcher to check the bag against."""
    counts: dict[str, int] = {}
    for gated in (gate for gate in gates if gate.kept):
        counts[gated.topic] = counts.get(gated.topic, 0) + gated.count
    leave(f"{node_name}.json", json.dumps(counts))
