"""The run loop a launcher supervises once its processes are started: wait for
the recorder, for the whole graph when part of it runs elsewhere, and for the
first tick; then for ``duration_s`` of control (sim seconds in lockstep, wall
seconds otherwise, respawning dead nodes if asked), or, on a launcher without
the simulator, until the other side's nodes have left the graph. What it found
is written into an ``Outcome``; ``launcher`` turns that into the run's result.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

from robot_controller.runner import supervise
from robot_controller.runner.plan import NODE_ORDER, RunPlan
from robot_controller.runner.processes import Child, ProcessGroup, say

#: The longest control period (10 Hz, the lowest control_rate_hz): a lockstep run's last tick is within it of its end.
LONGEST_PERIOD_S = 0.1


@dataclass
class Outcome:
    """What the run loop found, filled in as it goes; ``launch`` makes the run's result of it."""

    failure: str | None = None
    started: float | None = None  #: monotonic time the loop closed
    sim_start: float = 0.0
    control_seconds: float = 0.0
    wall_seconds: float = 0.0
    usage: dict[str, float] = field(default_factory=dict)
    interrupted: bool = False
    end_reason: str | None = None


Watcher = Callable[[float, dict[str, int]], None]


def run_loop(
    run: RunPlan,
    group: ProcessGroup,
    nodes: list[Child],
    link: supervise.RecorderLink,
    outcome: Outcome,
    watcher: Watcher | None,
    replaced: set[str] | None,
    viewers: list[Child],
    graph: supervise.GraphLink | None,
) -> None:
    """Wait for the recorder and the first tick, then for the options' ``duration_s`` of control; fills ``outcome``.

    :param replaced: respawn dead nodes, noting their names there (None: a dead node ends the run)
    :param viewers: observers measured apart (outside ``cpu_pct_total``) and never respawned
    :param graph: part of the graph runs here: wait (``wait_s``) for the other side's nodes first
    """
    duration_s = run.options.duration_s
    if run.records:
        outcome.failure = supervise.wait_recorder(link, group)
    if outcome.failure is None and graph is not None:
        outcome.failure = supervise.wait_graph(graph, group, NODE_ORDER, run.remote_nodes, run.options.wait_s)
        if outcome.failure is None:
            say(f"graph complete: {', '.join(NODE_ORDER)} (here: {', '.join(run.local_nodes)})")
    if outcome.failure is None and run.records:
        outcome.failure = supervise.wait_first_tick(link, group)
    if outcome.failure is not None:
        return
    started = outcome.started = time.monotonic()
    if not run.records:
        serve_until_the_loop_ends(run, group, nodes, graph, outcome, replaced)
        return
    say(f"control loop running; recording {duration_s:g} {'sim ' if run.sim_time else ''}s into {run.bag_dir}")
    meter = supervise.UsageMeter(group.children, started + min(supervise.USAGE_WARMUP_S, duration_s / 4))
    if viewers:
        meter = WithViewers(meter, viewers)
    if run.sim_time:
        outcome.sim_start, sim_start_taken_s = link.clock_s, link.clock_taken_s
        # The simulator's last tick is within a control period (0.1 s at most) of its end.
        last_tick_s = run.lockstep_end_s - LONGEST_PERIOD_S if run.lockstep_end_s else float("inf")
        outcome.failure = supervise.wait_sim(group, link, min(outcome.sim_start + duration_s, last_tick_s), meter)
        outcome.control_seconds = link.clock_s - outcome.sim_start
        # The wall time those control seconds took: between the recorder's receipts of the
        # two ticks (its reports, which the wait above polls, come only every 0.1 s).
        outcome.wall_seconds = link.clock_taken_s - sim_start_taken_s
        if outcome.failure is None and run.lockstep_end_s:
            # The simulator holds at the end: the recorder takes every tick before the nodes stop.
            outcome.failure = supervise.wait_sim(group, link, last_tick_s, meter)
    else:
        pids = {c.name: c.process.pid for c in nodes}
        poll = (lambda: watcher(time.monotonic() - started, pids)) if watcher else None
        respawn = _respawner(run, group, nodes, replaced, pids)
        outcome.failure = supervise.wait_wall(group, started + duration_s, meter, poll, respawn)
        outcome.control_seconds = outcome.wall_seconds = time.monotonic() - started
    outcome.usage = meter.finish()


def serve_until_the_loop_ends(
    run: RunPlan,
    group: ProcessGroup,
    nodes: list[Child],
    graph: supervise.GraphLink,
    outcome: Outcome,
    replaced: set[str] | None,
) -> None:
    """A launcher without the simulator: its nodes serve the loop until every node of the
    other side has left the graph (at once when that launcher stops them; after the DDS lease,
    20 s, if the link is cut for that long), which ends this run too, as a success."""
    started = outcome.started
    say(f"serving the loop with {', '.join(run.local_nodes)} until {', '.join(run.remote_nodes)} leave(s) the graph")
    meter = supervise.UsageMeter(group.children, started + supervise.USAGE_WARMUP_S)

    respawn = _respawner(run, group, nodes, replaced, {})
    ended = lambda: graph.all_gone(run.remote_nodes)  # noqa: E731
    outcome.failure = supervise.wait_wall(group, float("inf"), meter, None, respawn, ended=ended)
    outcome.control_seconds = outcome.wall_seconds = time.monotonic() - started
    outcome.usage = meter.finish()
    if outcome.failure is None:
        outcome.end_reason = f"{', '.join(run.remote_nodes)} left the graph: the loop has ended"


def _respawner(
    run: RunPlan, group: ProcessGroup, nodes: list[Child], replaced: set[str] | None, pids: dict[str, int]
) -> Callable[[Child], Child] | None:
    """What starts a dead node again, noting it in ``replaced`` and ``pids``; None without ``replaced``."""
    if replaced is None:
        return None

    def respawn(dead: Child) -> Child:
        replaced.add(dead.name)
        process = next(p for p in run.nodes if p.name == dead.name)
        child = group.restart(dead, env=process.env)
        nodes[nodes.index(dead)] = child
        pids[child.name] = child.process.pid
        return child

    return respawn


class WithViewers:
    """The run's usage meter, plus the viewers measured on their own (so
    ``cpu_pct_total`` stays the stack's), and a word if a viewer dies."""

    def __init__(self, meter: supervise.UsageMeter, viewers: list[Child]) -> None:
        self.meter = meter
        self.viewers = viewers
        self.viewer_meter = supervise.UsageMeter(viewers, meter.start_at)
        self.said: set[str] = set()

    def poll(self) -> None:
        self.meter.poll()
        self.viewer_meter.poll()
        for child in self.viewers:
            if child.name not in self.said and child.process.poll() is not None:
                self.said.add(child.name)
                say(f"{child.name} exited (code {child.process.returncode}): no live view; the run goes on")

    def forget(self, name: str) -> None:
        self.meter.forget(name)

    def finish(self) -> dict[str, float]:
        usage = self.meter.finish()
        names = {c.name for c in self.viewers}
        usage.update({k: v for k, v in self.viewer_meter.finish().items() if k.rsplit("_", 1)[-1] in names})
        return usage
