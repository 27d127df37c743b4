"""Run the graph as ``ros2 launch`` does: start what ``plan`` planned, supervise it (``supervise``), stop
it with SIGINT (SIGKILL for any that hang), the recorder last, and report what was recorded against
what the nodes say they published. The live viewer is an observer: its death does not end the run."""

from __future__ import annotations

import faulthandler
import json
import os
import shutil
import signal
import threading
import time
from pathlib import Path

from robot_controller.blocks import spec
from robot_controller.nodes import recorder as rec
from robot_controller.ros.process import (
    HOST_MISSED_FILE,
    LAW_FAULT_FILE,
    ROBOT_FAULT_FILE,
    ROBOT_TIMING_FILE,
    TEARDOWN_HUNG_SIGNAL,
    WORLD_CLOCK_FILE,
)
from robot_controller.runner import forking, supervise
from robot_controller.runner.plan import CheckedRun, plan
from robot_controller.runner.processes import ProcessGroup, say
from robot_controller.runner.supervise import RunResult, Watcher, run_loop

__all__ = ["RunResult", "launch", "say"]


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
    # SIGTERM (a CI timeout, `kill`) stops the run as cleanly as Ctrl-C, whatever handler was inherited.
    previous_sigterm = signal.signal(signal.SIGTERM, _raise_interrupt)
    previous_sigint = signal.signal(signal.SIGINT, _raise_interrupt)
    # `kill -USR1 <launcher>` prints where every thread of a launcher that seems stuck is.
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    link = supervise.RecorderLink(list(rec.topics_for(options.world_waits)))
    graph = supervise.GraphLink() if run.watcher is not None else None
    result = RunResult(run.bag_dir, run.records, options.nodes)
    replaced: set[str] = set()  # nodes killed and respawned
    try:
        # The viewer is kept out of the group's children: a dead viewer must not end the run.
        with ProcessGroup() as group, ProcessGroup() as viewers:
            wall_clock = not options.sim_time
            observers = [group.start(run.recorder, on_line=link.on_line, wall_clock=wall_clock)] if run.records else []
            if graph is not None:
                observers.append(group.start(run.watcher, on_line=graph.on_line, wall_clock=wall_clock))
            # All at once: the nodes' publishers wait for the recorder themselves.
            nodes = [group.start(process, wall_clock=wall_clock) for process in run.nodes]
            if run.viewer is not None:
                say(f"live view: {run.view_url}")
                viewers.start(run.viewer, wall_clock=wall_clock)
            try:
                group.relay()
                viewers.relay()
                # What scores and plots the run, imported while the nodes find each other.
                threading.Thread(target=_preload_reporting, daemon=True).start()
                respawn = replaced if options.respawn else None
                run_loop(run, group, nodes, link, result, watcher, respawn, viewers.children, graph)
            except KeyboardInterrupt:
                _interrupted(result, link, options.world_waits and run.records)
            # The nodes first, then the recorder, which takes what is still in flight (and the viewer).
            codes = group.stop(nodes)
            # The recorder drains what is still queued (rec.DRAIN_MAX_S at most), reporting, then closes the bag.
            heard = {"recorder": lambda: link.heard_s}
            codes.update(group.stop([*observers, *viewers.children], reported=heard))
            for child in viewers.children:  # a viewer's exit code is not the run's: only said
                code = codes.pop(child.name, None)
                if code not in (None, 0, -signal.SIGINT, 130):
                    say(f"WARNING: {child.name} exited with code {code} (the run itself is unaffected)")
        result.published_counts = _published_counts(run.counts_dir, replaced)
        world_file = run.counts_dir / WORLD_CLOCK_FILE  # a paced world's figures, written by the simulator
        if world_file.is_file():
            result.world_clock = json.loads(world_file.read_text())
        host_missed_file = run.counts_dir / HOST_MISSED_FILE  # the controller's, on the wall clock
        if host_missed_file.is_file():
            host_made = json.loads(host_missed_file.read_text())
            result.host_missed_ends_s = [float(t) for t in host_made.get("ends_s", [])]
            result.host_watchdog_s = [float(t) for t in host_made.get("watchdog_s", [])]
        fault_file = run.counts_dir / LAW_FAULT_FILE  # the controller's line on its law's failure, if any
        if fault_file.is_file() and (law_fault := fault_file.read_text().strip()):
            # The controller stopped the arm and ended itself (or the run ended first): say why, in one line.
            result.failure = f"the control law failed: {law_fault}"
        robot_fault_file = run.counts_dir / ROBOT_FAULT_FILE  # a robot's reflex, or its drive's death
        if robot_fault_file.is_file() and (robot_fault := robot_fault_file.read_text().strip()):
            result.failure = robot_fault
        robot_timing_file = run.counts_dir / ROBOT_TIMING_FILE
        if robot_timing_file.is_file():
            result.robot_timing = json.loads(robot_timing_file.read_text())
        if hung := sorted(n for n, c in codes.items() if c == -TEARDOWN_HUNG_SIGNAL):
            # Their counts were written and their messages acknowledged: the run is whole.
            say(f"WARNING: the DDS teardown of {', '.join(hung)} hung after its work was done (ended by its alarm)")
        bad = {n: c for n, c in codes.items() if c not in (0, -signal.SIGINT, 130, -TEARDOWN_HUNG_SIGNAL)}
        from robot_controller.scoring import (  # noqa: F401 - rosbags: preloaded while the nodes ran
            bag_reader,
            bag_recovery,
        )

        if salvaged := run.records and bag_recovery.needs_recovery(run.bag_dir):
            result.failure = result.failure or _salvage(run.bag_dir, bad.pop("recorder", None))
        if bad and result.failure is None:  # the run's data was complete: a warning
            said = ", ".join(f"{n} ({c})" for n, c in bad.items())
            say(f"WARNING: node(s) exited with an error on shutdown, after the run's data was complete: {said}")
    finally:
        signal.signal(signal.SIGTERM, previous_sigterm)
        signal.signal(signal.SIGINT, previous_sigint if previous_sigint is not None else signal.SIG_DFL)
        shutil.rmtree(run.counts_dir, ignore_errors=True)
    result.exit_code = 1 if result.failure else 0
    if run.records:  # what each topic's publishers say they sent: the bag must hold as many
        result.message_counts = dict(link.counts)
        (out_dir / "published.json").write_text(json.dumps(result.published_counts, indent=2, sort_keys=True) + "\n")
    if link.oversize:
        dropped = ", ".join(f"{t} {n}" for t, n in link.oversize.items())
        say(f"WARNING: messages over the recorder's size cap were dropped (not from this stack): {dropped}")
    if result.unrecorded and not salvaged:
        missed = ", ".join(f"{t} {n}" for t, n in result.unrecorded.items())
        say(f"WARNING: the bag misses messages the nodes published: {missed}")
    if result.failure:
        say(f"FAILED: {result.failure}")
    return result


def _interrupted(result: RunResult, link: supervise.RecorderLink, sim_time_recorded: bool) -> None:
    result.interrupted = True
    # A second Ctrl-C must not cut the stop short: the bag and the metrics come next.
    said = []

    def patient(signum, frame) -> None:
        if not said:
            said.append(True)
            # Straight to the file descriptor: no lock, no buffer the interrupted code may hold.
            os.write(1, b"[launcher] already stopping: nodes get 5 s to exit, then the recording is scored\n")

    signal.signal(signal.SIGINT, patient)
    signal.signal(signal.SIGTERM, patient)
    say("interrupted: stopping the nodes (the recording is kept and scored)")
    ran = link.counts.get(spec.STATE.topic) if result.recorded else result.started is not None
    result.failure = None if ran else "interrupted before the loop ran"
    if result.started is not None:
        result.wall_seconds = time.monotonic() - result.started
        result.control_seconds = link.clock_s - result.sim_start if sim_time_recorded else result.wall_seconds


def _salvage(bag_dir: Path, code: int | None) -> str | None:
    """The recorder ended (``code``) before closing its bag: its messages up to its last whole chunk into a
    complete bag, said in one line; a failure line if even that cannot be read."""
    try:
        from robot_controller.scoring.bag_recovery import recover

        count = recover(bag_dir)
    except (OSError, ValueError) as exc:
        return f"the recorder's bag could not be salvaged: {exc}"
    say(
        f"WARNING: the recorder ended (exit code {code}) before closing its bag: {count} messages salvaged up to"
        f" its last whole chunk (the torn bag kept as {bag_dir.name}.torn)"
    )
    return None


def _raise_interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def _published_counts(counts_dir: Path, replaced: set[str]) -> dict[str, int]:
    """Per topic, what the nodes say they published (a respawned node's topics left out: its count died with it)."""
    total: dict[str, int] = {}
    unknown: set[str] = set()
    for path in counts_dir.glob("*.json"):
        try:
            counts = {topic: int(count) for topic, count in json.loads(path.read_text()).items()}
        except (OSError, ValueError):
            continue
        if path.stem in replaced:
            unknown.update(counts)
        for topic, count in counts.items():
            total[topic] = total.get(topic, 0) + count
    return {topic: count for topic, count in total.items() if topic not in unknown}


def _preload_reporting() -> None:
    import matplotlib
    import rich.table  # noqa: F401

    from robot_controller.scoring import report  # noqa: F401 - rosbags

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401
