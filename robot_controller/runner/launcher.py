"""Start the five nodes as OS processes (or on one executor) beside a
recorder process, stop everything cleanly, then score the recording.

Like ``ros2 launch``: each child's output is prefixed with its name; Ctrl-C
or the end of ``duration`` stops them all with SIGINT, then SIGKILL for any
that hang; if a node dies the run ends with a non-zero exit. Children die
with the launcher even if it is killed (``PR_SET_PDEATHSIG``).

The recorder starts first and stops last, so the bag holds every message
the nodes published (each node writes its counts when it stops; the launcher
compares). Each child gets its place from ``scheduling``; the launcher
measures every child's CPU time and memory over the run.
"""
from __future__ import annotations

import faulthandler
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from typing import Any
from dataclasses import dataclass, field
from pathlib import Path

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.parameters import consistency as config_check
from robot_controller.ros import partition as dds_partition
from robot_controller.runner import forking
from robot_controller.runner import proc_stats
from robot_controller.ros import scheduling
from robot_controller.nodes.world_state import WORLD_STATE_ENV
from robot_controller.ros.publishing import COUNTS_DIR_ENV, RECORDED_ENV
from robot_controller.nodes import recorder as rec

NODE_ORDER = ("simulator", "motor_node", "sensor_node", "pid_controller", "trajectory_planner")
STOP_TIMEOUT_S = 5.0
FIRST_TICK_TIMEOUT_S = 20.0

# Re-entrant: a signal handler that prints must not deadlock on a print it interrupted.
_print_lock = threading.RLock()


def say(message: str) -> None:
    with _print_lock:
        print(f"[launcher] {message}", flush=True)


def _child_setup(place: scheduling.Placement) -> Callable[[], None]:
    def setup() -> None:  # runs in the child, first thing after the fork
        forking.die_with_parent()
        scheduling.apply_in_child(place)

    return setup


@dataclass
class Child:
    name: str
    process: forking.ForkedProcess
    reader: threading.Thread  #: relays its output; started by ``ProcessGroup.relay``
    module: str = ""
    args: list[str] = field(default_factory=list)


@dataclass
class ProcessGroup:
    """Child processes with prefixed output; a context manager that always stops them."""

    env: dict[str, str]
    children: list[Child] = field(default_factory=list)

    def start(self, name: str, module: str, args: list[str], *, env: dict[str, str] | None = None,
              on_line: Callable[[str], bool] | None = None, wall_clock: bool = True) -> Child:
        """Fork ``robot_controller.nodes.<module>`` as ``name`` with ``args``; ``on_line``
        sees each output line first and returns True for lines it consumed (not printed)."""
        process = forking.fork(module, [f"robot_controller.nodes.{module}", *args], env or self.env,
                               _child_setup(scheduling.placement(name, wall_clock)))
        reader = threading.Thread(target=self._relay, args=(name, process, on_line), daemon=True)
        child = Child(name, process, reader, module, args)
        self.children.append(child)
        return child

    @staticmethod
    def _relay(name: str, process: forking.ForkedProcess, on_line: Callable[[str], bool] | None) -> None:
        assert process.stdout is not None
        for line in process.stdout:
            if on_line is not None and on_line(line):
                continue
            with _print_lock:
                sys.stdout.write(f"[{name}] {line}")
                sys.stdout.flush()

    def restart(self, child: Child, *, env: dict[str, str]) -> Child:
        """Start a dead child again, same module and arguments (``--respawn``)."""
        child.reader.join(timeout=1.0)
        self.children.remove(child)
        again = self.start(child.name, child.module, child.args, env=env)
        self.relay()
        return again

    def relay(self) -> None:
        """Start relaying every child's output. Only once all are forked: a fork
        copies one thread, and the locks the others held, into the child."""
        for child in self.children:
            if not child.reader.is_alive() and child.reader.ident is None:
                child.reader.start()

    def dead(self) -> list[tuple[str, int]]:
        return [(c.name, c.process.returncode) for c in self.children if c.process.poll() is not None]

    def stop(self, children: list[Child] | None = None) -> dict[str, int]:
        """SIGINT ``children`` (default all), wait, then SIGKILL stragglers. Returns each one's exit code."""
        children = self.children if children is None else children
        for child in children:
            if child.process.poll() is None:
                try:
                    os.killpg(child.process.pid, signal.SIGINT)
                except ProcessLookupError:
                    pass
        deadline = time.monotonic() + STOP_TIMEOUT_S
        for child in children:
            try:
                child.process.wait(timeout=max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                say(f"{child.name} ignored SIGINT for {STOP_TIMEOUT_S:g} s: killing it")
                os.killpg(child.process.pid, signal.SIGKILL)
                child.process.wait()
        for child in children:
            if child.reader.ident is not None:
                child.reader.join(timeout=1.0)
        return {c.name: c.process.returncode for c in children}

    def __enter__(self) -> ProcessGroup:
        return self

    def __exit__(self, *exc_info) -> None:
        self.stop()


# Fast DDS sends from the publishing thread instead of handing each sample to
# a sender thread: measured, the lockstep runs 1.6× faster (RTF 3.8 against 2.4).
FASTDDS_PUBLICATION_MODE = ("RMW_FASTRTPS_PUBLICATION_MODE", "SYNCHRONOUS")


def child_env(single_process: bool) -> dict[str, str]:
    env = dict(os.environ)
    env.setdefault("PYTHONUNBUFFERED", "1")
    env.setdefault("RCUTILS_LOGGING_BUFFERED_STREAM", "0")
    env.setdefault("RCUTILS_COLORIZED_OUTPUT", "0")
    # The prefix already names the process; in one process the node name is needed.
    env.setdefault("RCUTILS_CONSOLE_OUTPUT_FORMAT",
                   "[{severity}] [{name}] {message}" if single_process else "[{severity}] {message}")
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    env.setdefault(*FASTDDS_PUBLICATION_MODE)
    env.setdefault("FASTRTPS_DEFAULT_PROFILES_FILE", str(resources.fastdds_profiles()))  # quick discovery
    env.pop(scheduling.PACING_RT_ENV, None)
    return env


def node_args(params_file: Path) -> list[str]:
    return ["--ros-args", "--params-file", str(params_file)]


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
        return {topic: sent - self.message_counts.get(topic, 0) for topic, sent in self.published_counts.items()
                if topic in self.message_counts and sent != self.message_counts.get(topic, 0)}


# Lockstep: no /clock progress for this long (wall) means the graph is stuck.
STALL_TIMEOUT_S = 10.0


# In lockstep the sensor steps on the stamps of what it receives and the
# controller and planner on /clock messages they read themselves, so they need no
# ROS sim time (and each such node would pay a /clock callback every tick).
# The motor's lag integrates over its clock, so it follows /clock.
SIM_TIME_NODES = ("motor_node",)


def lockstep_params(params: cfg.Params) -> cfg.Params:
    """The same parameters in sim-time lockstep: the simulator owns /clock and
    the simulator, controller and planner step on messages instead of timers."""
    out = cfg.merge(params, {})
    for node in cfg.NODES:
        out[node]["use_sim_time"] = node in SIM_TIME_NODES
    for node in ("simulator", "pid_controller", "trajectory_planner"):
        out[node]["lockstep"] = True
    return out


class RecorderLink:
    """What the recorder process reports on its stdout: ready, counts, /clock."""

    def __init__(self, topics: list[str]) -> None:
        self.ready = threading.Event()
        self.counts = {topic: 0 for topic in topics}
        self.oversize: dict[str, int] = {}  #: messages the recorder dropped as too large, per topic
        self.clock_s = 0.0

    def on_line(self, line: str) -> bool:
        if line.startswith(rec.PROGRESS_PREFIX):
            progress = json.loads(line[len(rec.PROGRESS_PREFIX):])
            self.counts, self.clock_s = progress["counts"], progress["clock_s"]
            self.oversize = progress.get("oversize", {})
            return True
        if line.strip() == rec.READY_LINE:
            self.ready.set()
            return True
        return False


RECORDER_READY_TIMEOUT_S = 30.0
# CPU and memory are measured from this long after the loop closes (start-up
# allocations and imports are not the loop's running cost) to its end.
USAGE_WARMUP_S = 2.0


def launch(params: cfg.Params, *, out_dir: Path, duration_s: float, single_process: bool = False,
           realtime: bool = False, sim_time: bool = False, domain_id: int | None = None,
           watcher: Callable[[float, dict[str, int]], None] | None = None, respawn: bool = False) -> RunResult:
    """Run the graph for ``duration_s`` seconds of control (sim seconds with
    ``sim_time``), recording into ``out_dir/bag``. ``realtime``: the
    simulator's pacing thread runs SCHED_FIFO (see ``scheduling``).
    ``domain_id``: the graph's ROS_DOMAIN_ID (default: this process's), so
    runs side by side do not hear each other. ``watcher(elapsed_s, pids)``
    is called about every 0.1 s while the loop runs (wall clock), with the
    seconds since the loop closed and each node's process id: the fault
    bench injects its faults from it. ``respawn``: a node that dies while the
    loop runs (wall clock) is started again, as ``ros2 launch``'s
    ``respawn=True`` does, instead of ending the run."""
    if sim_time:
        params = lockstep_params(params)
    config_check.check_stack(params)  # before anything is written or started
    out_dir.mkdir(parents=True, exist_ok=True)
    params_file = cfg.write_params_file(params, out_dir / "params.yaml")
    bag_dir = out_dir / "bag"
    if bag_dir.exists():
        raise FileExistsError(f"{bag_dir} exists: choose another --out")
    counts_dir = Path(tempfile.mkdtemp(prefix="robot-controller-counts-"))
    replaced: set[str] = set()  # nodes killed and respawned
    env = child_env(single_process)
    env.update({RECORDED_ENV: "1", COUNTS_DIR_ENV: str(counts_dir)})
    if respawn:
        env[WORLD_STATE_ENV] = str(counts_dir / "world_state.bin")
    if domain_id is not None:
        env["ROS_DOMAIN_ID"] = str(domain_id)
    if dds_partition.PROFILES_ENV in os.environ:
        say(f"{dds_partition.PROFILES_ENV} is set: the run uses that Fast DDS profile and is not isolated "
            "from other publishers on its domain")
    else:  # the run's loop topics in a partition of its own (see dds_partition)
        partition = dds_partition.new_partition()
        env[dds_partition.PROFILES_ENV] = str(dds_partition.write_run_profile(out_dir / "fastdds.xml", partition))
        env[dds_partition.PARTITION_ENV] = partition
    node_env = dict(env)
    if realtime:
        node_env[scheduling.PACING_RT_ENV] = str(scheduling.PACING_RT_PRIORITY)
    forking.preload()  # before any thread of this run: the children are forked from here
    # SIGTERM (a CI timeout, `kill`) stops the run as cleanly as Ctrl-C does.
    previous_sigterm = signal.signal(signal.SIGTERM, _raise_interrupt)
    # Ctrl-C explicitly too: whatever the process inherited or a library installed.
    previous_sigint = signal.signal(signal.SIGINT, _raise_interrupt)
    # `kill -USR1 <launcher>` prints where every thread of a launcher that seems stuck is.
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    link = RecorderLink(list(rec.topics_for(sim_time)))
    failure: str | None = None
    control_seconds = wall_seconds = 0.0
    usage: dict[str, float] = {}
    started: float | None = None
    sim_start = 0.0
    interrupted = False
    try:
        with ProcessGroup(env) as group:
            recorder = group.start("recorder", "recorder", [str(bag_dir)] + (["--sim-time"] if sim_time else []),
                                   on_line=link.on_line, wall_clock=not sim_time)
            nodes: list[Child] = []
            try:
                # All at once: the nodes' publishers wait for the recorder themselves.
                for name in ("stack",) if single_process else NODE_ORDER:
                    nodes.append(group.start(name, "all_in_one" if single_process else name,
                                             node_args(params_file), env=node_env, wall_clock=not sim_time))
                group.relay()
                # What scores and plots the run, imported while the nodes find each other.
                threading.Thread(target=_preload_reporting, daemon=True).start()
                failure = _wait_recorder(link, group)
                if failure is None:
                    failure = _wait_first_tick(link, group)
                if failure is None:
                    started = time.monotonic()
                    say(f"control loop running; recording {duration_s:g} {'sim ' if sim_time else ''}s "
                        f"into {bag_dir}")
                    meter = UsageMeter(group.children, started + min(USAGE_WARMUP_S, duration_s / 4))
                    if sim_time:
                        sim_start = link.clock_s
                        failure = _wait_sim(group, link, sim_start + duration_s, meter)
                        control_seconds = link.clock_s - sim_start
                    else:
                        pids = {c.name: c.process.pid for c in nodes}
                        poll = (lambda: watcher(time.monotonic() - started, pids)) if watcher else None
                        restart = None
                        if respawn:
                            def restart(dead: Child) -> Child:
                                replaced.add(dead.name)
                                child = group.restart(dead, env=node_env)
                                nodes[nodes.index(dead)] = child
                                pids[child.name] = child.process.pid
                                return child
                        failure = _wait(group, started + duration_s, meter, poll, restart)
                        control_seconds = time.monotonic() - started
                    wall_seconds = time.monotonic() - started
                    usage = meter.finish()
            except KeyboardInterrupt:
                interrupted = True
                # A second Ctrl-C must not cut the stop short: the bag and the metrics come next.
                patient = _patient_handler()
                signal.signal(signal.SIGINT, patient)
                signal.signal(signal.SIGTERM, patient)
                say("interrupted: stopping the nodes (the recording is kept and scored)")
                failure = None if link.counts.get("/controller/state") else "interrupted before the loop ran"
                if started is not None:
                    wall_seconds = time.monotonic() - started
                    control_seconds = link.clock_s - sim_start if sim_time else wall_seconds
            # The nodes first, then the recorder, which takes what is still in flight.
            codes = group.stop(nodes)
            codes.update(group.stop([recorder]))
        counts = dict(link.counts)
        published = _read_published_counts(counts_dir, replaced)
        bad = {n: c for n, c in codes.items() if c not in (0, -signal.SIGINT, 130)}
        if failure is None and bad:
            failure = "node(s) exited with an error on shutdown: " + ", ".join(f"{n} ({c})" for n, c in bad.items())
    finally:
        signal.signal(signal.SIGTERM, previous_sigterm)
        signal.signal(signal.SIGINT, previous_sigint if previous_sigint is not None else signal.SIG_DFL)
        shutil.rmtree(counts_dir, ignore_errors=True)
    # What each topic's publishers in the stack say they sent: the bag must hold as many.
    (out_dir / "published.json").write_text(json.dumps(published, indent=2, sort_keys=True) + "\n")
    result = RunResult(1 if failure else 0, bag_dir, control_seconds, wall_seconds, counts, failure, published,
                       usage, interrupted)
    if link.oversize:
        say("WARNING: messages over the recorder's size cap were dropped (not from this stack): "
            + ", ".join(f"{t} {n}" for t, n in link.oversize.items()))
    if result.unrecorded:
        say("WARNING: the bag misses messages the nodes published: "
            + ", ".join(f"{t} {n}" for t, n in result.unrecorded.items()))
    if failure:
        say(f"FAILED: {failure}")
    return result


def _preload_reporting() -> None:
    from robot_controller.scoring import report  # noqa: F401 - rosbags
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401
    import rich.table  # noqa: F401


class UsageMeter:
    """Samples every child (and this launcher) once at ``start_at`` and once at the end."""

    def __init__(self, children: list[Child], start_at: float) -> None:
        self.pids = {c.name: c.process.pid for c in children}
        self.start_at = start_at
        self.first: dict[str, proc_stats.Sample | None] | None = None
        self.first_time = 0.0

    def _sample(self) -> dict[str, proc_stats.Sample | None]:
        out = {name: proc_stats.sample(pid) for name, pid in self.pids.items()}
        out["launcher"] = proc_stats.self_sample()
        return out

    def forget(self, name: str) -> None:
        """A process that was replaced (respawned): its share is not measured."""
        self.pids.pop(name, None)
        if self.first is not None:
            self.first.pop(name, None)

    def poll(self) -> None:
        if self.first is None and time.monotonic() >= self.start_at:
            self.first, self.first_time = self._sample(), time.monotonic()

    def finish(self) -> dict[str, float]:
        if self.first is None:
            return {}
        return proc_stats.usage(self.first, self._sample(), time.monotonic() - self.first_time)


def _read_published_counts(counts_dir: Path, replaced: set[str] = frozenset()) -> dict[str, int]:
    """Per topic, what the nodes say they published. A node that was killed and
    respawned took its count with it: its topics are left out (unknown)."""
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


def _raise_interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def _patient_handler() -> Callable[[int, Any], None]:
    """After the first interrupt: further ones only say that the stop is under way."""
    said = [False]

    def handler(signum, frame) -> None:
        if not said[0]:
            said[0] = True
            # Straight to the file descriptor: no lock, no buffer the interrupted code may hold.
            os.write(1, b"[launcher] already stopping: nodes get 5 s to exit, then the recording is scored\n")

    return handler


def _wait_recorder(link: RecorderLink, group: ProcessGroup) -> str | None:
    deadline = time.monotonic() + RECORDER_READY_TIMEOUT_S
    while not link.ready.wait(0.05):
        if dead := group.dead():
            return _died(dead)
        if time.monotonic() > deadline:
            return f"the recorder was not ready within {RECORDER_READY_TIMEOUT_S:g} s"
    return None


def _wait_first_tick(link: RecorderLink, group: ProcessGroup) -> str | None:
    deadline = time.monotonic() + FIRST_TICK_TIMEOUT_S
    while not link.counts.get("/controller/state"):
        if dead := group.dead():
            return _died(dead)
        if time.monotonic() > deadline:
            return f"no /controller/state within {FIRST_TICK_TIMEOUT_S:g} s of start"
        time.sleep(0.02)
    return None


MAX_RESPAWNS = 5  # per node and run: a node that keeps dying ends the run


def _wait(group: ProcessGroup, until: float, meter: UsageMeter, poll: Callable[[], None] | None = None,
          restart: Callable[[Child], Child] | None = None) -> str | None:
    respawned: dict[str, int] = {}
    while (remaining := until - time.monotonic()) > 0:
        if dead := group.dead():
            children = [c for c in group.children if c.process.returncode is not None]
            if restart is None or any(c.name == "recorder" or respawned.get(c.name, 0) >= MAX_RESPAWNS
                                      for c in children):
                return _died(dead)
            for child in children:
                respawned[child.name] = respawned.get(child.name, 0) + 1
                say(f"{child.name} died (exit code {child.process.returncode}): respawning "
                    f"({respawned[child.name]} of {MAX_RESPAWNS})")
                meter.forget(child.name)
                restart(child)
        meter.poll()
        if poll is not None:
            poll()
        time.sleep(min(0.1, remaining))
    return None


def _wait_sim(group: ProcessGroup, link: RecorderLink, until_sim_s: float, meter: UsageMeter) -> str | None:
    last_clock, last_change = link.clock_s, time.monotonic()
    while link.clock_s < until_sim_s:
        if dead := group.dead():
            return _died(dead)
        meter.poll()
        if link.clock_s != last_clock:
            last_clock, last_change = link.clock_s, time.monotonic()
        elif time.monotonic() - last_change > STALL_TIMEOUT_S:
            return f"lockstep stalled at t = {last_clock:.3f} s: no tick for {STALL_TIMEOUT_S:g} s"
        time.sleep(0.01)
    return None


def _died(dead: list[tuple[str, int]]) -> str:
    return "node died: " + ", ".join(f"{name} (exit code {code})" for name, code in dead)
