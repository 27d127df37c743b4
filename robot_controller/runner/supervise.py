"""The run a launcher supervises once its processes are started (``run_loop``), what the recorder and
``graph_watch`` report to it, and what the run did (``RunResult``)."""

from __future__ import annotations

import bisect
import json
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from robot_controller.blocks import spec
from robot_controller.nodes import graph_watch
from robot_controller.nodes import recorder as rec
from robot_controller.ros.process import LAW_STOPPED_EXIT_CODE
from robot_controller.runner.options import NODE_ORDER
from robot_controller.runner.plan import RunPlan
from robot_controller.runner.processes import USAGE_WARMUP_S, Child, ProcessGroup, UsageMeter, say

RECORDER_READY_TIMEOUT_S = 30.0
CLOCK_WAIT_S = 10.0  #: a split run: the other launcher's clock is measured this long after the graph is complete
FIRST_TICK_TIMEOUT_S = 20.0
STALL_TIMEOUT_S = 10.0  #: sim time: no progress of the sim's clock for this long (wall) means the graph is stuck
GRAPH_SAY_EVERY_S = 5.0  #: how often the launcher names the nodes it is still waiting for
MAX_RESPAWNS = 5  #: per node and run: a node that keeps dying ends the run
#: The longest control period (10 Hz, the lowest control_rate_hz): a sim-time run's last tick is within it of its end.
LONGEST_PERIOD_S = 0.1

#: ``watcher(seconds since the loop closed, pids)``: the world's seconds on sim time (the paced world too)
Watcher = Callable[[float, dict[str, int]], None]


class RecorderLink:
    """What the recorder process reports on its stdout: ready, counts, the sim's clock."""

    def __init__(self, topics: list[str]) -> None:
        self.ready = threading.Event()
        self.counts = {topic: 0 for topic in topics}
        self.oversize: dict[str, int] = {}  #: messages the recorder dropped as too large, per topic
        self.clock_s = 0.0
        #: when (CLOCK_MONOTONIC s, the same in every process) the recorder took ``clock_s``, not when it said so
        self.clock_taken_s = 0.0
        #: ``(clock_taken_s, clock_s)`` at each new tick reported: maps an instant to the world's time
        self.clock_marks: list[tuple[float, float]] = []
        self.heard_s = 0.0  #: when (monotonic s) it last printed: a recorder stopping slowly still reports

    def on_line(self, line: str) -> bool:
        self.heard_s = time.monotonic()
        if line.startswith(rec.PROGRESS_PREFIX):
            progress = json.loads(line[len(rec.PROGRESS_PREFIX) :])
            self.counts, self.clock_s = progress["counts"], progress["clock_s"]
            self.clock_taken_s = progress.get("clock_taken_s", 0.0)
            if self.clock_taken_s and (not self.clock_marks or self.clock_marks[-1][1] != self.clock_s):
                self.clock_marks.append((self.clock_taken_s, self.clock_s))
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
        self.clock: dict | None = None  #: the latest ``@clock`` report (the recording launcher's watch)

    def on_line(self, line: str) -> bool:
        nodes = graph_watch.parse_line(line)
        if nodes is None:
            return self._on_clock(line)
        now = time.monotonic()
        self.nodes = frozenset(nodes)
        self.seen.update(nodes)
        for name in self.seen:
            if name in self.nodes:
                self.missing_since.pop(name, None)
            else:
                self.missing_since.setdefault(name, now)
        return True

    def _on_clock(self, line: str) -> bool:
        if not line.startswith(graph_watch.CLOCK_PREFIX):
            return False
        clock = json.loads(line[len(graph_watch.CLOCK_PREFIX) :])  # {peer, offset_ms, round_trip_ms, apart}
        if clock["apart"] and self.clock is not None and not self.clock["apart"]:  # said once as it goes past
            say(f"WARNING: the clocks drifted apart: {clock['apart']}")
        self.clock = clock
        return True

    def missing(self, names: tuple[str, ...]) -> list[str]:
        return [n for n in names if n not in self.nodes]

    def all_gone(self, names: tuple[str, ...]) -> bool:
        """Every one of ``names`` was seen and has been missing for ``GONE_AFTER_S``."""
        now = time.monotonic()
        return bool(names) and all(
            n in self.seen and now - self.missing_since.get(n, now) >= self.GONE_AFTER_S for n in names
        )


def wait_graph(
    graph: GraphLink, group: ProcessGroup, expected: tuple[str, ...], remote: tuple[str, ...], timeout_s: float
) -> str | None:
    """Wait until every node of ``expected`` is in the graph, naming the missing; a failure line after timing out."""
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


def wait_until(done: Callable[[], object], group: ProcessGroup, timeout_s: float, failure: str) -> str | None:
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
                count = f"{respawned[child.name]} of {MAX_RESPAWNS}"
                say(f"{child.name} died (exit code {child.process.returncode}): respawning ({count})")
                meter.forget(child.name)
                restart(child)
        meter.poll()
        if poll is not None:
            poll()
        time.sleep(min(0.1, remaining))
    return None


def wait_sim(
    group: ProcessGroup,
    link: RecorderLink,
    until_sim_s: float,
    meter: UsageMeter,
    watch: Callable[[], None] | None = None,
) -> str | None:
    last_clock, last_change = link.clock_s, time.monotonic()
    while link.clock_s < until_sim_s:
        if dead := group.dead():
            return died(dead)
        meter.poll()
        if watch is not None:
            watch()
        if link.clock_s != last_clock:
            last_clock, last_change = link.clock_s, time.monotonic()
        elif time.monotonic() - last_change > STALL_TIMEOUT_S:
            return f"sim time stalled at t = {last_clock:.3f} s: no tick for {STALL_TIMEOUT_S:g} s"
        time.sleep(0.01)
    return None


def died(dead: list[tuple[str, int]]) -> str:
    return "node died: " + ", ".join(f"{name} (exit code {code})" for name, code in dead)


@dataclass
class RunResult:
    """What a run did, filled in as it goes."""

    bag_dir: Path
    recorded: bool  #: False: part of the graph without the simulator (nothing to score)
    local_nodes: tuple[str, ...]  #: the nodes this launcher ran
    exit_code: int = 0
    failure: str | None = None
    control_seconds: float = 0.0  #: seconds of control recorded (sim seconds with sim time)
    wall_seconds: float = 0.0
    message_counts: dict[str, int] = field(default_factory=dict)  #: what the bag holds, per topic
    published_counts: dict[str, int] = field(default_factory=dict)  #: what the nodes say they sent
    usage: dict[str, float] = field(default_factory=dict)  #: cpu_pct_*, rss_* over the run (``usage``)
    interrupted: bool = False  #: Ctrl-C or SIGTERM ended it early (what was recorded is still scored)
    end_reason: str | None = None  #: why a launcher without the recorder ended
    started: float | None = None  #: monotonic time the loop closed
    sim_start: float = 0.0  #: the sim time the loop closed at
    world_clock: dict[str, float] = field(default_factory=dict)  #: a paced world's freezes and late efforts
    #: when (tick s) each missed cycle the host caused ended (the controller's, wall clock): not the loop's own
    host_missed_ends_s: list[float] = field(default_factory=list)
    #: when (tick s) each watchdog tick the host caused fell (its processes kept from a CPU past the window)
    host_watchdog_s: list[float] = field(default_factory=list)
    clocks: dict[str, float] = field(default_factory=dict)  #: a split run's clock offset and round trip, ms
    robot_timing: dict[str, float] = field(default_factory=dict)  #: a robot's clock over the run (``hardware``)
    #: sim time: ``(monotonic s, world s)`` at each tick the recorder reported (about every 0.1 s)
    clock_marks: list[tuple[float, float]] = field(default_factory=list)

    def raise_if_interrupted(self) -> None:
        """For a series of runs (faults, compare, bench): Ctrl-C ends the whole series, not just this run."""
        if self.interrupted:
            raise KeyboardInterrupt

    def world_time_at(self, monotonic_s: float, *, resuming: bool = False) -> float:
        """A paced world's time (s) at the instant ``monotonic_s`` (CLOCK_MONOTONIC), from the ticks reported about
        it, the world going at 1× between them and never past either. A pause in between (a frozen node: the world
        waits for it) is taken to come after the instant, or with ``resuming`` (the instant a freeze ended) before
        it: then the time is counted back from the next tick. NaN before the first tick reported."""
        marks = self.clock_marks
        before = bisect.bisect_right(marks, monotonic_s, key=lambda mark: mark[0]) - 1
        if before < 0:
            return float("nan")
        taken_s, world_s = marks[before]
        if before + 1 == len(marks):
            return world_s + (monotonic_s - taken_s)
        next_taken_s, next_world_s = marks[before + 1]
        if resuming:
            return max(world_s, next_world_s - (next_taken_s - monotonic_s))
        return min(world_s + (monotonic_s - taken_s), next_world_s)

    @property
    def real_time_factor(self) -> float:
        return self.control_seconds / self.wall_seconds if self.wall_seconds > 0 else float("nan")

    @property
    def unrecorded(self) -> dict[str, int]:
        """Messages published but missing from the bag, per topic (only topics the bag records)."""
        return {
            topic: sent - self.message_counts.get(topic, 0)
            for topic, sent in self.published_counts.items()
            if topic in self.message_counts and sent != self.message_counts.get(topic, 0)
        }


def run_loop(
    run: RunPlan,
    group: ProcessGroup,
    nodes: list[Child],
    link: RecorderLink,
    result: RunResult,
    watcher: Watcher | None,
    replaced: set[str] | None,
    viewers: list[Child],
    graph: GraphLink | None,
) -> None:
    """Wait for the recorder and the first tick, then for the options' ``duration_s`` of control.

    :param replaced: respawn dead nodes, noting their names there (None: a dead node ends the run)
    :param viewers: observers measured apart (outside ``cpu_pct_total``) and never respawned
    :param graph: part of the graph runs here: wait (``wait_s``) for the other side's nodes first
    """
    duration_s, sim_time, serving = run.options.duration_s, run.options.world_waits, not run.records
    here, there = ", ".join(run.options.nodes), ", ".join(run.remote_nodes)
    if run.records:
        failure = f"the recorder was not ready within {RECORDER_READY_TIMEOUT_S:g} s"
        result.failure = wait_until(link.ready.is_set, group, RECORDER_READY_TIMEOUT_S, failure)
    if result.failure is None and graph is not None:
        result.failure = wait_graph(graph, group, NODE_ORDER, run.remote_nodes, run.options.wait_s)
        if result.failure is None:
            say(f"graph complete: {', '.join(NODE_ORDER)} (here: {here})")
    if result.failure is None and graph is not None and run.watcher and "--ask" in run.watcher.args:
        # The drive ages a command by its clock from the controller's stamp: clocks apart refuse the run.
        failure = f"the other launcher's clock was not measured within {CLOCK_WAIT_S:g} s"
        result.failure = wait_until(lambda: graph.clock, group, CLOCK_WAIT_S, failure) or graph.clock["apart"]
        if graph.clock is not None:
            result.clocks = {f"clock_{k}": graph.clock[k] for k in ("offset_ms", "round_trip_ms")}
            say(f"clocks: {graph.clock['peer']} {graph.clock['offset_ms']:+.1f} ms from here")
    if result.failure is None and run.records:
        failure = f"no {spec.STATE.topic} within {FIRST_TICK_TIMEOUT_S:g} s of start"
        result.failure = wait_until(lambda: link.counts.get(spec.STATE.topic), group, FIRST_TICK_TIMEOUT_S, failure)
    if result.failure is not None:
        return
    started = result.started = time.monotonic()
    if serving:
        say(f"serving the loop with {here} until {there} leave(s) the graph")
    else:
        say(f"control loop running; recording {duration_s:g} {'sim ' if sim_time else ''}s into {run.bag_dir}")
    meter = UsageMeter(group.children, started + min(USAGE_WARMUP_S, duration_s / 4), viewers)
    pids = {c.name: c.process.pid for c in nodes}
    if sim_time and not serving:
        result.sim_start, sim_start_taken_s = link.clock_s, link.clock_taken_s
        result.clock_marks = link.clock_marks  # filled on as the recorder reports
        # The simulator's last tick is within a control period (0.1 s at most) of its end.
        last_tick_s = run.sim_end_s - LONGEST_PERIOD_S if run.sim_end_s else float("inf")
        # The world's time since the loop closed: a host pause before a fault does not move where it strikes.
        watch = (lambda: watcher(link.clock_s - result.sim_start, pids)) if watcher else None
        result.failure = wait_sim(group, link, min(result.sim_start + duration_s, last_tick_s), meter, watch)
        result.control_seconds = link.clock_s - result.sim_start
        # The wall time they took: between the recorder's receipts of the two ticks (it reports every 0.1 s).
        result.wall_seconds = link.clock_taken_s - sim_start_taken_s
        if result.failure is None and run.sim_end_s:
            # The simulator holds at the end: the recorder takes every tick before the nodes stop.
            result.failure = wait_sim(group, link, last_tick_s, meter)
    else:

        def respawn(dead: Child) -> Child:
            replaced.add(dead.name)
            child = group.restart(dead)
            nodes[nodes.index(dead)] = child
            pids[child.name] = child.process.pid
            return child

        # A launcher without the simulator serves until the other side has left the graph (at once when
        # that launcher stops its nodes; after the DDS lease, 20 s, if the link is cut that long): a success.
        result.failure = wait_wall(
            group,
            float("inf") if serving else started + duration_s,
            meter,
            (lambda: watcher(time.monotonic() - started, pids)) if watcher else None,
            respawn if replaced is not None else None,
            (lambda: graph.all_gone(run.remote_nodes)) if serving else None,
        )
        result.control_seconds = result.wall_seconds = time.monotonic() - started
        if serving and result.failure is None:
            result.end_reason = f"{there} left the graph: the loop has ended"
    result.usage = meter.finish()
