"""How many rclpy round trips per second two processes on this machine can make.

An echo process re-publishes every message it hears; this process publishes,
waits for the echo, publishes the next (one message in flight) for a fixed
wall time. Same transport settings as the stack's nodes: Fast DDS with
synchronous publication, localhost discovery, the EventsExecutor, reliable
volatile QoS, normal scheduling.

Why: a lockstep tick of the stack is two round trips (simulator → sensor →
controller → motor → simulator), so ``round_trips_per_s() / 2 / control_rate_hz``
bounds the lockstep real-time factor this machine can reach.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import subprocess
import sys
import time

import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import Float64MultiArray

PING, PONG = "/hop_bench/ping", "/hop_bench/pong"
QOS = QoSProfile(
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
    history=HistoryPolicy.KEEP_LAST,
    depth=10,
)
ENV = {"RMW_FASTRTPS_PUBLICATION_MODE": "SYNCHRONOUS", "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
MATCH_TIMEOUT_S, WARMUP_S, PING_PERIOD_S = 30.0, 0.5, 0.05


def _executor(kind: str, context):
    if kind == "events":
        from rclpy.experimental import EventsExecutor

        return EventsExecutor(context=context)
    return SingleThreadedExecutor(context=context)


def _echo(executor_kind: str) -> None:
    """The echo side: ROS_DOMAIN_ID and the rest come from the environment."""
    stop = []  # a signal ends the loop between callbacks, so cleanup runs in order
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.append(True))
    node = rclpy.create_node("hop_bench_echo")
    pub = node.create_publisher(Float64MultiArray, PONG, QOS)
    node.create_subscription(Float64MultiArray, PING, pub.publish, QOS)
    executor = _executor(executor_kind, None)
    executor.add_node(node)
    parent = os.getppid()
    try:
        while not stop and rclpy.ok() and os.getppid() == parent:  # ends with the measuring process too
            executor.spin_once(timeout_sec=0.1)
    finally:
        executor.shutdown(timeout_sec=1.0)
        node.destroy_node()
        rclpy.try_shutdown()


@contextlib.contextmanager
def _like_the_nodes():
    """The nodes' DDS settings (read when the participant is made) and SCHED_OTHER
    for this thread and the DDS threads it starts; the caller's are restored after."""
    saved_env = {key: os.environ.get(key) for key in ENV}
    policy, param = os.sched_getscheduler(0), os.sched_getparam(0)
    os.environ.update(ENV)
    if policy != os.SCHED_OTHER:
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    try:
        yield
    finally:
        for key, value in saved_env.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
        if policy != os.SCHED_OTHER:
            with contextlib.suppress(OSError):
                os.sched_setscheduler(0, policy, param)


def round_trips_per_s(duration_s: float = 5.0, domain_id: int | None = None, executor: str = "events") -> float:
    """Ping-pong round trips per second against an echo process, over ``duration_s`` of wall time."""
    if domain_id is None:
        domain_id = int(os.environ.get("ROS_DOMAIN_ID", "0") or 0)
    if executor not in ("events", "single"):
        raise ValueError(f"executor must be 'events' or 'single', not {executor!r}")
    child_env = {**os.environ, **ENV, "ROS_DOMAIN_ID": str(domain_id)}
    echo = subprocess.Popen(
        [sys.executable, "-m", "robot_controller_lab.hop_bench", "--echo", "--executor", executor],
        env=child_env,
        preexec_fn=lambda: os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0)),
    )
    try:
        with _bench_node("hop_bench_ping", domain_id, executor) as (node, pub, spinner):
            state = {"seq": 0, "done": 0}
            msg = Float64MultiArray()

            def send() -> None:
                state["seq"] += 1
                msg.data = [float(state["seq"]), 0.0, 0.0]
                pub.publish(msg)

            def on_pong(reply: Float64MultiArray) -> None:
                if reply.data[0] == state["seq"]:  # not a stale warm-up echo
                    state["done"] += 1
                    send()

            node.create_subscription(Float64MultiArray, PONG, on_pong, QOS)
            give_up = time.monotonic() + MATCH_TIMEOUT_S
            while state["done"] == 0:  # matched both ways once an echo comes back
                if time.monotonic() > give_up or echo.poll() is not None:
                    raise RuntimeError(f"no echo within {MATCH_TIMEOUT_S} s (echo exit code {echo.poll()})")
                send()
                next_ping = time.monotonic() + PING_PERIOD_S
                while state["done"] == 0 and time.monotonic() < next_ping:
                    spinner.spin_once(timeout_sec=PING_PERIOD_S)
            for seconds in (WARMUP_S, duration_s):  # the last pass is the timed one
                start, done0 = time.perf_counter(), state["done"]
                while time.perf_counter() < start + seconds:
                    spinner.spin_once(timeout_sec=0.1)
            return (state["done"] - done0) / (time.perf_counter() - start)
    finally:
        echo.terminate()
        try:
            echo.wait(timeout=3.0)
        except subprocess.TimeoutExpired:
            echo.kill()
            echo.wait()


def message_cpu_s(duration_s: float = 5.0, domain_id: int | None = None, period_s: float = 0.001) -> float:
    """CPU seconds (the whole process's: the executor's thread and DDS's) per message that one process publishes
    from a timer every ``period_s`` and hears itself, EventsExecutor: the timer's wake-up, the publish, the
    message's wake-up, the take and the callback.

    Why: in one process the loop's nodes trade every value as such a message, each waking an executor that
    slept since the last, so this times a tick's plumbing (a 1 kHz tick in one process carries at least six)
    apart from its arithmetic."""
    if domain_id is None:
        domain_id = int(os.environ.get("ROS_DOMAIN_ID", "0") or 0)
    with _bench_node("hop_bench_self", domain_id, "events") as (node, pub, spinner):
        state = {"heard": 0}
        msg = Float64MultiArray(data=[0.0, 0.0, 0.0])

        def on_ping(_: Float64MultiArray) -> None:
            state["heard"] += 1

        node.create_subscription(Float64MultiArray, PING, on_ping, QOS)
        node.create_timer(period_s, lambda: pub.publish(msg))
        give_up = time.monotonic() + MATCH_TIMEOUT_S
        while state["heard"] == 0:  # its own reader matched once a message comes back
            if time.monotonic() > give_up:
                raise RuntimeError(f"the process did not hear itself within {MATCH_TIMEOUT_S} s")
            spinner.spin_once(timeout_sec=PING_PERIOD_S)
        for seconds in (WARMUP_S, duration_s):  # the last pass is the timed one
            start, cpu0, heard0 = time.perf_counter(), time.process_time(), state["heard"]
            while time.perf_counter() < start + seconds:
                spinner.spin_once(timeout_sec=0.1)
        return (time.process_time() - cpu0) / max(1, state["heard"] - heard0)


@contextlib.contextmanager
def _bench_node(name: str, domain_id: int, executor: str):
    """A node of ``name`` on its own context (made as the loop's nodes are), its publisher on ``PING`` and its
    spinning executor; all torn down after."""
    context = rclpy.Context()
    node = spinner = None
    try:
        with _like_the_nodes():
            rclpy.init(context=context, domain_id=domain_id)
            node = rclpy.create_node(name, context=context)
            pub = node.create_publisher(Float64MultiArray, PING, QOS)
            spinner = _executor(executor, context)
            spinner.add_node(node)
            yield node, pub, spinner
    finally:
        if spinner is not None:
            spinner.shutdown(timeout_sec=1.0)
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown(context=context)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--echo", action="store_true", help="run the echo side (started by the measuring side)")
    parser.add_argument("--executor", choices=("events", "single"), default="events")
    parser.add_argument("--duration", type=float, default=5.0, help="seconds of timed ping-pong")
    parser.add_argument("--domain", type=int, default=None, help="ROS_DOMAIN_ID (default: the environment's)")
    args = parser.parse_args(argv)
    if args.echo:
        _echo(args.executor)
        return
    rate = round_trips_per_s(args.duration, args.domain, args.executor)
    print(f"{rate:.0f} round trips/s ({args.executor} executor, {args.duration:g} s)")
    cpu_s = message_cpu_s(args.duration, args.domain)
    print(f"{cpu_s * 1e6:.0f} µs of CPU per message one process publishes at 1 kHz and hears itself (events executor)")


if __name__ == "__main__":
    main()
