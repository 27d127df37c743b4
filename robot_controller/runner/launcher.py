"""Run the graph: plan it (``plan``: which processes, which parameters, all
checked and written before anything starts), start the recorder and the
nodes (``processes``), watch them until the run's duration is recorded
(``supervise``), stop them all and report what was recorded against what the
nodes say they published.

Like ``ros2 launch``: each child's output is prefixed with its name; Ctrl-C
or the end of ``duration`` stops them all with SIGINT, then SIGKILL for any
that hang; if a node dies the run ends with a non-zero exit (or, with
``respawn``, it is started again). The recorder starts first and stops last,
so the bag holds every message the nodes published.

With ``view_port`` a viewer (``nodes.viewer``) also runs beside the
recorder: an observer that serves the live view in a browser and saves
``view.rrd``. Nothing waits for it, and its death does not end the run.

Part of the graph (``nodes``; docs/design.md §6 "Across hosts"): a
``graph_watch`` observer reports the graph's nodes; the launcher waits (at
most ``wait_s``) until all five are there, naming the missing ones. The
launcher with the simulator records, then runs for ``duration_s`` as always;
one without it records nothing and runs until every node of the other side
has left the graph (the loop it serves has ended), which is a success.

The run loop it supervises, and a split run's serving until the other side
leaves, are in ``run_loop``.
"""

from __future__ import annotations

import faulthandler
import json
import math
import shutil
import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from robot_controller import parameters as cfg
from robot_controller.nodes import recorder as rec
from robot_controller.ros.process import TEARDOWN_HUNG_SIGNAL
from robot_controller.runner import forking, supervise
from robot_controller.runner.plan import plan
from robot_controller.runner.processes import STOP_TIMEOUT_S, Child, ProcessGroup, say
from robot_controller.runner.run_loop import Outcome, run_loop

__all__ = ["RunResult", "launch", "say"]

#: Sim seconds the simulator runs past a lockstep run's --duration (its end: lockstep_end_s).
LOCKSTEP_END_MARGIN_S = 0.5


@dataclass
class RunResult:
    exit_code: int
    bag_dir: Path
    control_seconds: float  #: seconds of control recorded (sim seconds with sim time)
    wall_seconds: float
    message_counts: dict[str, int]
    failure: str | None = None
    published_counts: dict[str, int] = field(default_factory=dict)  #: what the nodes say they sent
    usage: dict[str, float] = field(default_factory=dict)  #: cpu_pct_*, rss_* over the run (proc_stats)
    interrupted: bool = False  #: Ctrl-C or SIGTERM ended it early (what was recorded is still scored)
    recorded: bool = True  #: False: part of the graph without the simulator (nothing to score)
    local_nodes: tuple[str, ...] = ()  #: the nodes this launcher ran
    end_reason: str | None = None  #: why a launcher without the recorder ended

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


def launch(
    params: cfg.Params,
    *,
    out_dir: Path,
    duration_s: float,
    single_process: bool = False,
    realtime: bool = False,
    sim_time: bool = False,
    domain_id: int | None = None,
    watcher: Callable[[float, dict[str, int]], None] | None = None,
    respawn: bool = False,
    view_port: int | None = None,
    nodes: tuple[str, ...] | None = None,
    peers: list[str] | None = None,
    run_id: str | None = None,
    wait_s: float = supervise.GRAPH_WAIT_S,
) -> RunResult:
    """Run the graph for ``duration_s`` seconds of control (sim seconds with
    ``sim_time``), recording into ``out_dir/bag``. ``realtime``: the
    simulator's pacing thread runs SCHED_FIFO (see ``scheduling``).
    ``domain_id``: the graph's ROS_DOMAIN_ID (default: this process's), so
    runs side by side do not hear each other. ``watcher(elapsed_s, pids)``
    is called about every 0.1 s while the loop runs (wall clock), with the
    seconds since the loop closed and each node's process id: the fault
    bench injects its faults from it. ``respawn``: a node that dies while the
    loop runs (wall clock) is started again, as ``ros2 launch``'s
    ``respawn=True`` does, instead of ending the run. ``view_port``: serve
    the live view at ``http://127.0.0.1:<view_port>`` (and save
    ``out_dir/view.rrd``) from a viewer process beside the recorder.
    ``nodes``, ``peers``, ``run_id``: start only part of the graph, with the other
    hosts' addresses, in the run named so (``plan``); ``wait_s``: how long to wait
    for the whole graph before giving up."""
    if sim_time and math.isfinite(duration_s):
        # The simulator stops a little past the end (the loop's first tick comes a moment after
        # t = 0): the graph falls quiet and the recorder takes every message before the nodes stop.
        params = cfg.merge(params, {"simulator": {"lockstep_end_s": duration_s + LOCKSTEP_END_MARGIN_S}})
    run = plan(
        params,
        out_dir=out_dir,
        single_process=single_process,
        realtime=realtime,
        sim_time=sim_time,
        domain_id=domain_id,
        respawn=respawn,
        view_port=view_port,
        nodes=nodes,
        peers=peers,
        run_id=run_id,
    )
    for note in run.notes:
        say(note)
    forking.preload()  # before any thread of this run: the children are forked from here
    # SIGTERM (a CI timeout, `kill`) stops the run as cleanly as Ctrl-C does.
    previous_sigterm = signal.signal(signal.SIGTERM, supervise.raise_interrupt)
    # Ctrl-C explicitly too: whatever the process inherited or a library installed.
    previous_sigint = signal.signal(signal.SIGINT, supervise.raise_interrupt)
    # `kill -USR1 <launcher>` prints where every thread of a launcher that seems stuck is.
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    link = supervise.RecorderLink(list(rec.topics_for(sim_time)))
    graph = supervise.GraphLink() if run.watcher is not None else None
    outcome = Outcome()
    replaced: set[str] = set()  # nodes killed and respawned
    try:
        # The viewer is kept out of the group's children: a dead viewer must not end the run.
        with ProcessGroup(run.nodes[0].env) as group, ProcessGroup(run.nodes[0].env) as viewers:
            observers = []
            if run.recorder is not None:
                observers.append(
                    group.start(
                        "recorder",
                        run.recorder.module,
                        run.recorder.args,
                        env=run.recorder.env,
                        on_line=link.on_line,
                        wall_clock=not sim_time,
                    )
                )
            if graph is not None:
                observers.append(
                    group.start(
                        run.watcher.name,
                        run.watcher.module,
                        run.watcher.args,
                        env=run.watcher.env,
                        on_line=graph.on_line,
                        wall_clock=not sim_time,
                    )
                )
            # All at once: the nodes' publishers wait for the recorder themselves.
            nodes = [group.start(p.name, p.module, p.args, env=p.env, wall_clock=not sim_time) for p in run.nodes]
            if run.viewer is not None:
                say(f"live view: {run.view_url}")
                viewers.start(
                    run.viewer.name, run.viewer.module, run.viewer.args, env=run.viewer.env, wall_clock=not sim_time
                )
            try:
                group.relay()
                viewers.relay()
                # What scores and plots the run, imported while the nodes find each other.
                threading.Thread(target=_preload_reporting, daemon=True).start()
                run_loop(
                    run,
                    group,
                    nodes,
                    link,
                    outcome,
                    duration_s,
                    watcher,
                    replaced if respawn else None,
                    viewers.children,
                    graph,
                    wait_s,
                )
            except KeyboardInterrupt:
                outcome.interrupted = True
                # A second Ctrl-C must not cut the stop short: the bag and the metrics come next.
                patient = supervise.patient_handler()
                signal.signal(signal.SIGINT, patient)
                signal.signal(signal.SIGTERM, patient)
                say("interrupted: stopping the nodes (the recording is kept and scored)")
                ran = link.counts.get("/controller/state") if run.records else outcome.started is not None
                outcome.failure = None if ran else "interrupted before the loop ran"
                if outcome.started is not None:
                    outcome.wall_seconds = time.monotonic() - outcome.started
                    outcome.control_seconds = (
                        link.clock_s - outcome.sim_start if sim_time and run.records else outcome.wall_seconds
                    )
            # The nodes first, then the recorder, which takes what is still in flight (and the viewer).
            codes = group.stop(nodes)
            # The recorder drains what is still queued (rec.DRAIN_MAX_S at most) before it closes the bag.
            codes.update(group.stop([*observers, *viewers.children], timeout_s=rec.DRAIN_MAX_S + STOP_TIMEOUT_S))
            _report_viewer(viewers.children, codes)
        published = supervise.read_published_counts(run.counts_dir, replaced)
        if law_fault := supervise.read_law_fault(run.counts_dir):
            # The controller stopped the arm and ended itself (or the run ended first): say why, in one line.
            outcome.failure = f"the control law failed: {law_fault}"
        hung = sorted(n for n, c in codes.items() if c == -TEARDOWN_HUNG_SIGNAL)
        if hung:
            # Their counts were written and their messages acknowledged: the run is whole.
            say(f"WARNING: the DDS teardown of {', '.join(hung)} hung after its work was done (ended by its alarm)")
        bad = {n: c for n, c in codes.items() if c not in (0, -signal.SIGINT, 130, -TEARDOWN_HUNG_SIGNAL)}
        if outcome.failure is None and bad:
            outcome.failure = "node(s) exited with an error on shutdown: " + ", ".join(
                f"{n} ({c})" for n, c in bad.items()
            )
    finally:
        signal.signal(signal.SIGTERM, previous_sigterm)
        signal.signal(signal.SIGINT, previous_sigint if previous_sigint is not None else signal.SIG_DFL)
        shutil.rmtree(run.counts_dir, ignore_errors=True)
    # What each topic's publishers in the stack say they sent: the bag must hold as many.
    if run.records:
        (out_dir / "published.json").write_text(json.dumps(published, indent=2, sort_keys=True) + "\n")
    result = RunResult(
        1 if outcome.failure else 0,
        run.bag_dir,
        outcome.control_seconds,
        outcome.wall_seconds,
        dict(link.counts) if run.records else {},  # nothing recorded here: nothing to compare with
        outcome.failure,
        published,
        outcome.usage,
        outcome.interrupted,
        run.records,
        run.local_nodes,
        outcome.end_reason,
    )
    if link.oversize:
        say(
            "WARNING: messages over the recorder's size cap were dropped (not from this stack): "
            + ", ".join(f"{t} {n}" for t, n in link.oversize.items())
        )
    if result.unrecorded:
        say(
            "WARNING: the bag misses messages the nodes published: "
            + ", ".join(f"{t} {n}" for t, n in result.unrecorded.items())
        )
    if outcome.failure:
        say(f"FAILED: {outcome.failure}")
    return result


def _report_viewer(viewers: list[Child], codes: dict[str, int]) -> None:
    """A viewer's exit code is not the run's: it is taken out of ``codes`` and only reported."""
    for child in viewers:
        code = codes.pop(child.name, None)
        if code not in (None, 0, -signal.SIGINT, 130):
            say(f"WARNING: {child.name} exited with code {code} (the run itself is unaffected)")


def _preload_reporting() -> None:
    import matplotlib
    import rich.table  # noqa: F401

    from robot_controller.scoring import report  # noqa: F401 - rosbags

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401
