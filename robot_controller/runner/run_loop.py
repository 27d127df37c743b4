"""The run a launcher supervises once its processes are started: wait for the recorder, for the whole
graph when part of it runs elsewhere, and for the first tick; then for ``duration_s`` of control (sim
seconds in lockstep, wall seconds otherwise, respawning dead nodes if asked), or, on a launcher without
the simulator, until the other side's nodes have left the graph. What it finds goes into the ``RunResult``."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from robot_controller.runner import supervise
from robot_controller.runner.options import NODE_ORDER
from robot_controller.runner.plan import RunPlan
from robot_controller.runner.processes import Child, ProcessGroup, say
from robot_controller.runner.usage import USAGE_WARMUP_S, UsageMeter

#: The longest control period (10 Hz, the lowest control_rate_hz): a lockstep run's last tick is within it of its end.
LONGEST_PERIOD_S = 0.1

Watcher = Callable[[float, dict[str, int]], None]


@dataclass
class RunResult:
    """What a run did, filled in as it goes (``run_loop``, then ``launch``)."""

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

    def raise_if_interrupted(self) -> None:
        """For a series of runs (faults, compare, bench): Ctrl-C ends the whole series, not just this run."""
        if self.interrupted:
            raise KeyboardInterrupt

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
    link: supervise.RecorderLink,
    result: RunResult,
    watcher: Watcher | None,
    replaced: set[str] | None,
    viewers: list[Child],
    graph: supervise.GraphLink | None,
) -> None:
    """Wait for the recorder and the first tick, then for the options' ``duration_s`` of control.

    :param replaced: respawn dead nodes, noting their names there (None: a dead node ends the run)
    :param viewers: observers measured apart (outside ``cpu_pct_total``) and never respawned
    :param graph: part of the graph runs here: wait (``wait_s``) for the other side's nodes first
    """
    duration_s, sim_time, serving = run.options.duration_s, run.options.sim_time, not run.records
    here, there = ", ".join(run.options.nodes), ", ".join(run.remote_nodes)
    if run.records:
        result.failure = supervise.wait_recorder(link, group)
    if result.failure is None and graph is not None:
        result.failure = supervise.wait_graph(graph, group, NODE_ORDER, run.remote_nodes, run.options.wait_s)
        if result.failure is None:
            say(f"graph complete: {', '.join(NODE_ORDER)} (here: {here})")
    if result.failure is None and run.records:
        result.failure = supervise.wait_first_tick(link, group)
    if result.failure is not None:
        return
    started = result.started = time.monotonic()
    if serving:
        say(f"serving the loop with {here} until {there} leave(s) the graph")
    else:
        say(f"control loop running; recording {duration_s:g} {'sim ' if sim_time else ''}s into {run.bag_dir}")
    meter = UsageMeter(group.children, started + min(USAGE_WARMUP_S, duration_s / 4), viewers)
    if sim_time and not serving:
        result.sim_start, sim_start_taken_s = link.clock_s, link.clock_taken_s
        # The simulator's last tick is within a control period (0.1 s at most) of its end.
        last_tick_s = run.lockstep_end_s - LONGEST_PERIOD_S if run.lockstep_end_s else float("inf")
        result.failure = supervise.wait_sim(group, link, min(result.sim_start + duration_s, last_tick_s), meter)
        result.control_seconds = link.clock_s - result.sim_start
        # The wall time those control seconds took: between the recorder's receipts of the
        # two ticks (its reports, which the wait above polls, come only every 0.1 s).
        result.wall_seconds = link.clock_taken_s - sim_start_taken_s
        if result.failure is None and run.lockstep_end_s:
            # The simulator holds at the end: the recorder takes every tick before the nodes stop.
            result.failure = supervise.wait_sim(group, link, last_tick_s, meter)
    else:
        pids = {c.name: c.process.pid for c in nodes}

        def respawn(dead: Child) -> Child:
            replaced.add(dead.name)
            child = group.restart(dead)
            nodes[nodes.index(dead)] = child
            pids[child.name] = child.process.pid
            return child

        # A launcher without the simulator serves until the other side has left the graph (at once when
        # that launcher stops its nodes; after the DDS lease, 20 s, if the link is cut that long): a success.
        result.failure = supervise.wait_wall(
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
