"""Publishing that waits for its audience: a gate holds what a node publishes
until its consumer (and, when the run is recorded, the recorder) has matched,
so nothing the loop sends is lost to discovery; each gate counts what it sent.

A gate needs three things of the node that owns it (:class:`GateOwner`): the
rclpy calls that make its publisher and its poll timer, whether the node runs
in lockstep, and a place to keep it. ``StackNode`` is such an owner, and
writes its gates' counts (:func:`write_publish_counts`) when it stops."""

from __future__ import annotations

import copy
import json
import os
import time
from collections import deque
from typing import Any, Protocol

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import QoSProfile

from robot_controller.ros.qos import CONTROL_QOS

# Nodes that only watch (the recorder, a viewer) do not count as consumers.
RECORDER_NODE = "recorder"
VIEWER_NODE = "viewer"
OBSERVER_NODES = frozenset({RECORDER_NODE, VIEWER_NODE})
# In lockstep the recorder says here (rosgraph_msgs/Clock) which tick it has taken,
# so the simulator never runs further ahead of it than its queues hold.
RECORDER_CLOCK_TOPIC = "/recorder/clock"

# Set by the launcher when a recorder runs: every publisher then also waits
# for the recorder, so the bag holds every message the loop ever sent.
RECORDED_ENV = "ROBOT_CONTROLLER_RECORDED"
# Where each node writes how many messages it published, per topic, when it
# stops (the launcher compares them with the bag).
COUNTS_DIR_ENV = "ROBOT_CONTROLLER_COUNTS_DIR"


def recorded() -> bool:
    return os.environ.get(RECORDED_ENV, "") == "1"


# Discovery is two-sided: a writer can see a reader before the reader knows
# the writer, and the reader drops what arrives in between. A reader counts
# as matched once it has been seen for this long.
MATCH_SETTLE_S = 0.25


def has_consumer(node: Node, topic: str) -> bool:
    """Whether a node other than an observer subscribes to ``topic``."""
    return any(info.node_name not in OBSERVER_NODES for info in node.get_subscriptions_info_by_topic(topic))


def has_recorder(node: Node, topic: str) -> bool:
    return any(info.node_name == RECORDER_NODE for info in node.get_subscriptions_info_by_topic(topic))


class ConsumerWatch:
    """``ready()`` once the audience of ``topic`` has been seen for ``MATCH_SETTLE_S`` (wall time).

    The audience is a consumer (unless ``consumer`` is False) and, when the
    run is recorded, the recorder: both in the graph by name, and as many
    readers actually matched by ``publisher`` (DDS matching honours the run's
    partition; the graph does not, and a node of an earlier run on the same
    domain can linger in it for a moment).
    """

    def __init__(self, node: Node, topic: str, *, consumer: bool = True, publisher: Any = None) -> None:
        self.node, self.topic = node, topic
        self.consumer = consumer
        self.recorder = recorded()
        self.publisher = publisher
        self.seen_since: float | None = None

    def present(self) -> bool:
        named = (not self.consumer or has_consumer(self.node, self.topic)) and (
            not self.recorder or has_recorder(self.node, self.topic)
        )
        if not named or self.publisher is None:
            return named
        return self.publisher.get_subscription_count() >= int(self.consumer) + int(self.recorder)

    def ready(self) -> bool:
        if not self.present():
            self.seen_since = None
            return False
        now = time.monotonic()
        if self.seen_since is None:
            self.seen_since = now
        return now - self.seen_since >= MATCH_SETTLE_S


MAX_HELD = 1000  # messages a gate holds at most (10 s of a 100 Hz topic)


class GateOwner(Protocol):
    """What a :class:`GatedPublisher` needs of the node it belongs to."""

    #: The node runs in sim-time lockstep: every message is a tick, and a gate holds them all.
    lockstep: bool

    def create_publisher(self, msg_type: Any, topic: str, qos_profile: QoSProfile) -> Any: ...

    def create_timer(self, timer_period_sec: float, callback: Any, *, clock: Clock) -> Any: ...

    def destroy_timer(self, timer: Any) -> bool: ...

    def get_logger(self) -> Any: ...

    def get_subscriptions_info_by_topic(self, topic_name: str) -> list[Any]: ...

    def keep_gated_publisher(self, gated: GatedPublisher) -> None:
        """Keep ``gated`` among the node's gates (their counts are written when it stops)."""


class GatedPublisher:
    """Holds what is published until its audience (a consumer and, when the run
    is recorded, the recorder) has matched, then publishes; counts what it published.

    In lockstep nothing is ever re-sent (a re-sent effort would double a
    tick), so the first message must not go out before anyone listens; in
    wall-clock mode only the newest held message is worth sending.
    ``consumer=False``: telemetry, whose only audience is the recorder.
    """

    def __init__(
        self, node: GateOwner, msg_type: Any, topic: str, *, consumer: bool = True, qos: QoSProfile = None
    ) -> None:
        self.node, self.topic = node, topic
        self.publisher = node.create_publisher(msg_type, topic, qos or CONTROL_QOS)
        self.watch = ConsumerWatch(node, topic, consumer=consumer, publisher=self.publisher)
        self.open = not consumer and not self.watch.recorder
        # Held until open: every message for telemetry and in lockstep (each is a
        # tick, and the bag must hold them all), only the newest for a wall-clock
        # consumer (an old reading or torque is worth nothing).
        self.hold_all = not consumer or node.lockstep
        self.count = 0
        self.pending: deque[Any] = deque(maxlen=MAX_HELD if self.hold_all else 1)
        self._poll = None
        if not self.open:
            self._poll = node.create_timer(0.05, self._check, clock=Clock(clock_type=ClockType.STEADY_TIME))
        node.keep_gated_publisher(self)

    def publish(self, msg: Any) -> None:
        if self.open:
            self.publisher.publish(msg)
            self.count += 1
        else:
            # Held for the poll timer to flush: publish() may run on a thread of
            # the node's own (the simulator's pacing), the timer on the executor.
            self.pending.append(copy.deepcopy(msg))

    def _check(self) -> None:
        if self.open or not self.watch.ready():
            return
        self.open = True
        self.node.destroy_timer(self._poll)
        self.node.get_logger().debug(f"{self.topic}: audience matched, publishing")
        while self.pending:  # popleft, not iteration: another thread may still append
            self.publisher.publish(self.pending.popleft())
            self.count += 1


def publish_counts(gates: list[GatedPublisher]) -> dict[str, int]:
    """How many messages ``gates`` published, per topic."""
    counts: dict[str, int] = {}
    for gated in gates:
        counts[gated.topic] = counts.get(gated.topic, 0) + gated.count
    return counts


def write_publish_counts(node_name: str, counts: dict[str, int]) -> None:
    """A node's published-message counts, for the launcher to check the bag against."""
    counts_dir = os.environ.get(COUNTS_DIR_ENV, "")
    if not counts_dir:
        return
    try:
        with open(os.path.join(counts_dir, f"{node_name}.json"), "w") as f:
            json.dump(counts, f)
    except OSError:
        pass
