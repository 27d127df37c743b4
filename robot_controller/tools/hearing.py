"""Waiting until a tool's message will be heard: the node it talks to has matched the tool's
publisher, and discovery has settled, before the tool sends."""

from __future__ import annotations

import time
from typing import Any

# Discovery is two-sided and staggered: a reader seen by this writer may not know the writer yet,
# and the run's recorder may be found after the node a tool talks to. A tool sends once the readers
# found have all matched and nothing has changed for MATCH_SETTLE_S, or for UNMATCHED_SETTLE_S if
# some never match (readers in a partition this process does not write to).
MATCH_SETTLE_S = 1.0
UNMATCHED_SETTLE_S = 1.5
#: the readers that record or draw a topic: heard by them alone, a message reached no node
TOOL_OBSERVERS = frozenset({"recorder"})


def matching(node: Any, publisher: Any, topic: str, listener: str) -> tuple[int, int] | None:
    """``(readers listed, readers matched)`` once the node ``listener`` subscribes to ``topic``
    and a reader besides the observers has matched ``publisher``, else None (the graph lists
    every partition's readers; matching is per partition)."""
    readers = node.get_subscriptions_info_by_topic(topic)
    if not any(info.node_name == listener for info in readers):
        return None
    observers = sum(info.node_name in TOOL_OBSERVERS for info in readers)
    if observers == 0 and TOOL_OBSERVERS & set(node.get_node_names()):
        return None  # a recorder is in the graph but its reader not yet listed: it would miss the message
    matched = publisher.get_subscription_count()
    return (len(readers), matched) if matched > observers else None


def wait_until_heard(node: Any, publisher: Any, topic: str, listener: str, *, since: float, wait_s: float) -> bool:
    """Whether ``listener`` came to hear ``publisher`` on ``topic`` (:func:`matching`, settled)
    within ``wait_s`` seconds of ``since`` (``time.monotonic()``)."""
    seen, seen_since = None, since
    while True:
        now = time.monotonic()
        found = matching(node, publisher, topic, listener)
        if found != seen:
            seen, seen_since = found, now
        elif found is not None and now - seen_since >= (MATCH_SETTLE_S if found[1] >= found[0] else UNMATCHED_SETTLE_S):
            return True
        if now - since > wait_s:
            return False
        time.sleep(0.05)
