"""Watching a run while it goes: what the recorder and ``graph_watch`` report (ready, counts, /clock,
the graph's nodes) and the waits for the loop to close and to end (a dead node, a stalled lockstep,
respawns)."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable

from robot_controller.nodes import graph_watch
from robot_controller.nodes import recorder as rec
from robot_controller.ros.process import LAW_STOPPED_EXIT_CODE
from robot_controller.runner.processes import Child, ProcessGroup, say
from robot_controller.runner.usage import UsageMeter

RECORDER_READY_TIMEOUT_S = 30.0
FIRST_TICK_TIMEOUT_S = 20.0
STALL_TIMEOUT_S = 10.0  #: lockstep: no /clock progress for this long (wall) means the graph is stuck
GRAPH_SAY_EVERY_S = 5.0  #: how often the launcher names the nodes it is still waiting for
MAX_RESPAWNS = 5  #: per node and run: a node that keeps dying ends the run


class RecorderLink:
    """What the recorder process reports on its stdout: ready, counts, /clock."""

    def __init__(self, topics: list[str]) -> None:
        self.ready = threading.Event()
        self.counts = {topic: 0 for topic in topics}
        self.oversize: dict[str, int] = {}  #: messages the recorder dropped as too large, per topic
        self.clock_s = 0.0
        #: when (CLOCK_MONOTONIC s, the same in every process) the recorder took ``clock_s``: the
        #: lockstep real-time factor is timed on these, not on when its report came (every 0.1 s)
        self.clock_taken_s = 0.0

    def on_line(self, line: str) -> bool:
        if line.startswith(rec.PROGRESS_PREFIX):
            progress = json.loads(line[len(rec.PROGRESS_PREFIX) :])
            self.counts, self.clock_s = progress["counts"], progress["clock_s"]
            self.clock_taken_s = progress.get("clock_taken_s", 0.0)
            self.oversize = progress.get("oversize", {})
            return True
        if line.strip() == rec.READY_LINE:
            self.ready.set()
            return True
        return False


class GraphLink:
    """What the ``graph_watch`` process reports: the nodes in the graph (a split run)."""

    #: a node of the other side counts as gone once missing from the graph this long (s)
    GONE_AFTER_S = 1.0

    def __init__(self) -> None:
        self.nodes: frozenset[str] = frozenset()
        self.seen: set[str] = set()  #: every node ever seen
        self.missing_since: dict[str, float] = {}

    def on_line(self, line: str) -> bool:
        nodes = graph_watch.parse_line(line)
        if nodes is None:
            return False
        now = time.monotonic()
        self.nodes = frozenset(nodes)
        self.seen.update(nodes)
        for name in self.seen:
            if name in self.nodes:
                self.missing_since.pop(name, None)
            else:
                self.missing_since.setdefault(name, now)
        return True

    def missing(self, names: tuple[str, ...]) -> list[str]:
        return [n for n in names if n not in self.nodes]

    def all_gone(self, names: tuple[str, ...]) -> bool:
        """Every one of ``names`` was seen and has been missing for ``GONE_AFTER_S`` (a node respawned
        meanwhile, or one of several, does not count: the loop they serve goes on)."""
        now = time.monotonic()
        return bool(names) and all(
            n in self.seen and now - self.missing_since.get(n, now) >= self.GONE_AFTER_S for n in names
        )


def wait_graph(
    graph: GraphLink, group: ProcessGroup, expected: tuple[str, ...], remote: tuple[str, ...], timeout_s: float
) -> str | None:
    """Wait until every node of ``expected`` is in the graph, naming the missing ones every
    ``GRAPH_SAY_EVERY_S`` (those of ``remote`` as the other launcher's); a failure line after
    ``timeout_s``."""
    start = time.monotonic()
    next_say = start + 1.0
    while missing := graph.missing(expected):
        if dead := group.dead():
            return died(dead)
        now = time.monotonic()
        where = [f"{n} (other launcher)" if n in remote else n for n in missing]
        if now - start > timeout_s:
            return (
                f"the graph was not complete within {timeout_s:g} s (--wait): missing {', '.join(where)}; "
                "check the other launcher's --run-id, --peers and ROS_DOMAIN_ID"
            )
        if now >= next_say:
            say(f"waiting for {', '.join(where)} ({now - start:.0f} s of {timeout_s:g})")
            next_say = now + GRAPH_SAY_EVERY_S
        time.sleep(0.05)
    return None


def wait_recorder(link: RecorderLink, group: ProcessGroup) -> str | None:
    failure = f"the recorder was not ready within {RECORDER_READY_TIMEOUT_S:g} s"
    return _wait_until(link.ready.is_set, group, RECORDER_READY_TIMEOUT_S, failure)


def wait_first_tick(link: RecorderLink, group: ProcessGroup) -> str | None:
    failure = f"no /controller/state within {FIRST_TICK_TIMEOUT_S:g} s of start"
    return _wait_until(lambda: link.counts.get("/controller/state"), group, FIRST_TICK_TIMEOUT_S, failure)


def _wait_until(done: Callable[[], object], group: ProcessGroup, timeout_s: float, failure: str) -> str | None:
    """None once ``done()``; a line naming what died, or ``failure`` after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not done():
        if dead := group.dead():
            return died(dead)
        if time.monotonic() > deadline:
            return failure
        time.sleep(0.02)
    return None


def wait_wall(
    group: ProcessGroup,
    until: float,
    meter: UsageMeter,
    poll: Callable[[], None] | None = None,
    restart: Callable[[Child], Child] | None = None,
    ended: Callable[[], bool] | None = None,
) -> str | None:
    """Watch the nodes until ``until`` (monotonic s), or until ``ended()`` says the run is over."""
    respawned: dict[str, int] = {}
    while (remaining := until - time.monotonic()) > 0 and not (ended is not None and ended()):
        if dead := group.dead():
            children = [c for c in group.children if c.process.returncode is not None]
            if restart is None or any(
                c.name == "recorder"
                or c.process.returncode == LAW_STOPPED_EXIT_CODE  # the law failed: restarting runs it again
                or respawned.get(c.name, 0) >= MAX_RESPAWNS
                for c in children
            ):
                return died(dead)
            for child in children:
                respawned[child.name] = respawned.get(child.name, 0) + 1
                say(
                    f"{child.name} died (exit code {child.process.returncode}): respawning "
                    f"({respawned[child.name]} of {MAX_RESPAWNS})"
                )
                meter.forget(child.name)
                restart(child)
        meter.poll()
        if poll is not None:
            poll()
        time.sleep(min(0.1, remaining))
    return None


def wait_sim(group: ProcessGroup, link: RecorderLink, until_sim_s: float, meter: UsageMeter) -> str | None:
    last_clock, last_change = link.clock_s, time.monotonic()
    while link.clock_s < until_sim_s:
        if dead := group.dead():
            return died(dead)
        meter.poll()
        if link.clock_s != last_clock:
            last_clock, last_change = link.clock_s, time.monotonic()
        elif time.monotonic() - last_change > STALL_TIMEOUT_S:
            return f"lockstep stalled at t = {last_clock:.3f} s: no tick for {STALL_TIMEOUT_S:g} s"
        time.sleep(0.01)
    return None


def died(dead: list[tuple[str, int]]) -> str:
    return "node died: " + ", ".join(f"{name} (exit code {code})" for name, code in dead)
