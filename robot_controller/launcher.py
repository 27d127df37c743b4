"""Start the five nodes as OS processes (or on one executor), record the run,
stop everything cleanly, then score the recording.

Like ``ros2 launch``: each child's output is prefixed with its name; Ctrl-C
or the end of ``duration`` stops them all with SIGINT, then SIGKILL for any
that hang; if a node dies the run ends with a non-zero exit. Children die
with the launcher even if it is killed (``PR_SET_PDEATHSIG``).
"""
from __future__ import annotations

import ctypes
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from robot_controller import config as cfg

NODE_ORDER = ("simulator", "motor_node", "sensor_node", "pid_controller", "trajectory_planner")
STOP_TIMEOUT_S = 5.0
FIRST_TICK_TIMEOUT_S = 60.0

_print_lock = threading.Lock()


def say(message: str) -> None:
    with _print_lock:
        print(f"[launcher] {message}", flush=True)


def _die_with_parent() -> None:  # runs in the child between fork and exec
    try:
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
    except OSError:
        pass


@dataclass
class Child:
    name: str
    process: subprocess.Popen
    reader: threading.Thread


@dataclass
class ProcessGroup:
    """Child processes with prefixed output; a context manager that always stops them."""

    env: dict[str, str]
    children: list[Child] = field(default_factory=list)

    def start(self, name: str, argv: list[str]) -> Child:
        process = subprocess.Popen(
            argv, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=self.env,
            start_new_session=True, preexec_fn=_die_with_parent, bufsize=1, text=True, errors="replace")
        reader = threading.Thread(target=self._relay, args=(name, process), daemon=True)
        reader.start()
        child = Child(name, process, reader)
        self.children.append(child)
        return child

    @staticmethod
    def _relay(name: str, process: subprocess.Popen) -> None:
        assert process.stdout is not None
        for line in process.stdout:
            with _print_lock:
                sys.stdout.write(f"[{name}] {line}")
                sys.stdout.flush()

    def dead(self) -> list[tuple[str, int]]:
        return [(c.name, c.process.returncode) for c in self.children if c.process.poll() is not None]

    def stop(self) -> dict[str, int]:
        """SIGINT all, wait, then SIGKILL stragglers. Returns each child's exit code."""
        for child in self.children:
            if child.process.poll() is None:
                try:
                    os.killpg(child.process.pid, signal.SIGINT)
                except ProcessLookupError:
                    pass
        deadline = time.monotonic() + STOP_TIMEOUT_S
        for child in self.children:
            try:
                child.process.wait(timeout=max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                say(f"{child.name} ignored SIGINT for {STOP_TIMEOUT_S:g} s: killing it")
                os.killpg(child.process.pid, signal.SIGKILL)
                child.process.wait()
        for child in self.children:
            child.reader.join(timeout=1.0)
        return {c.name: c.process.returncode for c in self.children}

    def __enter__(self) -> ProcessGroup:
        return self

    def __exit__(self, *exc_info) -> None:
        self.stop()


# SCHED_FIFO priority asked for the nodes (where permitted): above everything
# else on the machine, below the kernel's own threads (50). The recorder, in
# this process, sits just above the nodes: a recording that loses samples
# under load is worse than a loop that runs a little slower.
DEFAULT_RT_PRIORITY = 20
RECORDER_RT_PRIORITY = 21


# Fast DDS sends from the publishing thread instead of handing each sample to
# a sender thread: measured, the lockstep runs 1.6× faster (RTF 3.8 against 2.4).
FASTDDS_PUBLICATION_MODE = ("RMW_FASTRTPS_PUBLICATION_MODE", "SYNCHRONOUS")


def child_env(single_process: bool, realtime: bool = True) -> dict[str, str]:
    env = dict(os.environ)
    if realtime:
        env.setdefault("ROBOT_CONTROLLER_RT_PRIORITY", str(DEFAULT_RT_PRIORITY))
    else:
        env.pop("ROBOT_CONTROLLER_RT_PRIORITY", None)
    env.setdefault("PYTHONUNBUFFERED", "1")
    env.setdefault("RCUTILS_LOGGING_BUFFERED_STREAM", "0")
    env.setdefault("RCUTILS_COLORIZED_OUTPUT", "0")
    # The prefix already names the process; in one process the node name is needed.
    env.setdefault("RCUTILS_CONSOLE_OUTPUT_FORMAT",
                   "[{severity}] [{name}] {message}" if single_process else "[{severity}] {message}")
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    env.setdefault(*FASTDDS_PUBLICATION_MODE)
    return env


def node_argv(name: str, params_file: Path) -> list[str]:
    return [sys.executable, "-m", f"robot_controller.nodes.{name}", "--ros-args", "--params-file",
            str(params_file)]


@dataclass
class RunResult:
    exit_code: int
    bag_dir: Path
    control_seconds: float  #: seconds of control recorded (sim seconds with sim time)
    wall_seconds: float
    message_counts: dict[str, int]
    failure: str | None = None

    @property
    def real_time_factor(self) -> float:
        return self.control_seconds / self.wall_seconds if self.wall_seconds > 0 else float("nan")


# Lockstep: no /clock progress for this long (wall) means the graph is stuck.
STALL_TIMEOUT_S = 10.0


# In lockstep the sensor and controller step on the stamps of what they
# receive and the planner on /clock messages it reads itself, so they need no
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


def launch(params: cfg.Params, *, out_dir: Path, duration_s: float, single_process: bool = False,
           realtime: bool = True, sim_time: bool = False) -> RunResult:
    """Run the graph for ``duration_s`` seconds of control (sim seconds with
    ``sim_time``), recording into ``out_dir/bag``."""
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    from robot_controller.nodes.recorder import BagRecorder

    out_dir.mkdir(parents=True, exist_ok=True)
    if sim_time:
        params = lockstep_params(params)
    params_file = cfg.write_params_file(params, out_dir / "params.yaml")
    bag_dir = out_dir / "bag"
    if bag_dir.exists():
        raise FileExistsError(f"{bag_dir} exists: choose another --out")

    saved_policy = (os.sched_getscheduler(0), os.sched_getparam(0))
    if realtime:
        from robot_controller.nodes.base import request_realtime_priority

        note = request_realtime_priority(str(RECORDER_RT_PRIORITY))
        if note:
            say(f"recorder {note}")
    # SIGTERM (a CI timeout, `kill`) stops the run as cleanly as Ctrl-C does.
    previous_sigterm = signal.signal(signal.SIGTERM, _raise_interrupt)
    os.environ.setdefault(*FASTDDS_PUBLICATION_MODE)  # the recorder, in this process
    context = rclpy.Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
    failure: str | None = None
    control_seconds = wall_seconds = 0.0
    try:
        with BagRecorder(context, bag_dir, sim_time=sim_time) as recorder, ProcessGroup(child_env(single_process, realtime)) as group:
            if single_process:
                group.start("stack", node_argv("all_in_one", params_file))
            else:
                for name in NODE_ORDER:
                    group.start(name, node_argv(name, params_file))
            try:
                failure = _wait_first_tick(recorder, group)
                if failure is None:
                    started = time.monotonic()
                    say(f"control loop running; recording {duration_s:g} {'sim ' if sim_time else ''}s "
                        f"into {bag_dir}")
                    if sim_time:
                        sim_start = recorder.clock_s
                        failure = _wait_sim(group, recorder, sim_start + duration_s)
                        control_seconds = recorder.clock_s - sim_start
                    else:
                        failure = _wait(group, started + duration_s)
                        control_seconds = time.monotonic() - started
                    wall_seconds = time.monotonic() - started
            except KeyboardInterrupt:
                say("interrupted: stopping the nodes")
                failure = None if recorder.counts["/controller/state"] else "interrupted before the loop ran"
            codes = group.stop()
            counts = dict(recorder.counts)
        bad = {n: c for n, c in codes.items() if c not in (0, -signal.SIGINT, 130)}
        if failure is None and bad:
            failure = "node(s) exited with an error on shutdown: " + ", ".join(f"{n} ({c})" for n, c in bad.items())
    finally:
        rclpy.try_shutdown(context=context)
        signal.signal(signal.SIGTERM, previous_sigterm)
        try:
            os.sched_setscheduler(0, *saved_policy)
        except OSError:
            pass
    if failure:
        say(f"FAILED: {failure}")
    return RunResult(1 if failure else 0, bag_dir, control_seconds, wall_seconds, counts, failure)


def _raise_interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def _wait_first_tick(recorder, group: ProcessGroup) -> str | None:
    deadline = time.monotonic() + FIRST_TICK_TIMEOUT_S
    while not recorder.counts["/controller/state"]:
        if dead := group.dead():
            return _died(dead)
        if time.monotonic() > deadline:
            return f"no /controller/state within {FIRST_TICK_TIMEOUT_S:g} s of start"
        recorder.event.wait(0.1)
        recorder.event.clear()
    return None


def _wait(group: ProcessGroup, until: float) -> str | None:
    while (remaining := until - time.monotonic()) > 0:
        if dead := group.dead():
            return _died(dead)
        time.sleep(min(0.1, remaining))
    return None


def _wait_sim(group: ProcessGroup, recorder, until_sim_s: float) -> str | None:
    last_clock, last_change = recorder.clock_s, time.monotonic()
    while recorder.clock_s < until_sim_s:
        if dead := group.dead():
            return _died(dead)
        if recorder.clock_s != last_clock:
            last_clock, last_change = recorder.clock_s, time.monotonic()
        elif time.monotonic() - last_change > STALL_TIMEOUT_S:
            return f"lockstep stalled at t = {last_clock:.3f} s: no tick for {STALL_TIMEOUT_S:g} s"
        time.sleep(0.02)
    return None


def _died(dead: list[tuple[str, int]]) -> str:
    return "node died: " + ", ".join(f"{name} (exit code {code})" for name, code in dead)
