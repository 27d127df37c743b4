"""Run the graph as ``ros2 launch`` does: start what ``plan`` planned (the recorder first, then the
nodes, each child's output prefixed with its name), supervise the run (``run_loop``), stop them all
with SIGINT (Ctrl-C, SIGTERM or the end of the duration; SIGKILL for any that hang), the recorder
last, and report what was recorded against what the nodes say they published. A node that dies ends
the run with a non-zero exit, or starts again with ``respawn``. The live viewer is an observer:
nothing waits for it and its death does not end the run.
"""

from __future__ import annotations

import faulthandler
import json
import shutil
import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from robot_controller.nodes import recorder as rec
from robot_controller.ros.process import TEARDOWN_HUNG_SIGNAL
from robot_controller.runner import forking, supervise
from robot_controller.runner.plan import CheckedRun, Process, plan
from robot_controller.runner.processes import STOP_TIMEOUT_S, Child, ProcessGroup, say
from robot_controller.runner.run_loop import Outcome, Watcher, run_loop

__all__ = ["RunResult", "launch", "say"]


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


def launch(checked: CheckedRun, out_dir: Path, watcher: Watcher | None = None) -> RunResult:
    """Run the graph for the options' ``duration_s`` of control, recording into ``out_dir/bag``.

    :param watcher: called about every 0.1 s while the loop runs (wall clock) with the seconds since
        the loop closed and each node's process id (the fault bench injects its faults from it)
    """
    run = plan(checked, out_dir)
    options = run.options
    for note in run.notes:
        say(note)
    forking.preload()  # before any thread of this run: the children are forked from here
    # SIGTERM (a CI timeout, `kill`) stops the run as cleanly as Ctrl-C does.
    previous_sigterm = signal.signal(signal.SIGTERM, supervise.raise_interrupt)
    # Ctrl-C explicitly too: whatever the process inherited or a library installed.
    previous_sigint = signal.signal(signal.SIGINT, supervise.raise_interrupt)
    # `kill -USR1 <launcher>` prints where every thread of a launcher that seems stuck is.
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    link = supervise.RecorderLink(list(rec.topics_for(options.sim_time)))
    graph = supervise.GraphLink() if run.watcher is not None else None
    outcome = Outcome()
    replaced: set[str] = set()  # nodes killed and respawned
    try:
        # The viewer is kept out of the group's children: a dead viewer must not end the run.
        with ProcessGroup(run.nodes[0].env) as group, ProcessGroup(run.nodes[0].env) as viewers:

            def start(into: ProcessGroup, process: Process, on_line: Callable[[str], bool] | None = None) -> Child:
                return into.start(
                    process.name,
                    process.module,
                    process.args,
                    env=process.env,
                    on_line=on_line,
                    wall_clock=not options.sim_time,
                )

            observers = [start(group, run.recorder, link.on_line)] if run.recorder is not None else []
            if graph is not None:
                observers.append(start(group, run.watcher, graph.on_line))
            # All at once: the nodes' publishers wait for the recorder themselves.
            nodes = [start(group, process) for process in run.nodes]
            if run.viewer is not None:
                say(f"live view: {run.view_url}")
                start(viewers, run.viewer)
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
                    watcher,
                    replaced if options.respawn else None,
                    viewers.children,
                    graph,
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
                        link.clock_s - outcome.sim_start if options.sim_time and run.records else outcome.wall_seconds
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
