"""What every tool shares: one short-lived, hidden rclpy node on the current ROS_DOMAIN_ID, spinning in a thread, that
hears every run's DDS partition (``ros.partition``) through an observer profile named in this process's environment
only, unless the user chose one (``FASTRTPS_DEFAULT_PROFILES_FILE``). Discovery stays on this host unless
``ROS_AUTOMATIC_DISCOVERY_RANGE`` says otherwise. rclpy is imported only when a tool runs."""

from __future__ import annotations

import contextlib
import functools
import importlib
import os
import queue
import shutil
import signal
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

#: How long a tool waits for a topic or a node's service to appear.
DISCOVERY_TIMEOUT_S = 5.0
#: One service call: how long each attempt waits for its answer, and how many attempts.
CALL_ATTEMPT_S = 2.5
CALL_ATTEMPTS = 4
POLL_S = 0.02
#: How long a sent message may take to be acknowledged by every reader.
DELIVERY_TIMEOUT_S = 2.0

DISCOVERY_RANGE_ENV = "ROS_AUTOMATIC_DISCOVERY_RANGE"


class ToolError(Exception):
    """Something the user should read: one line on stderr, and the exit code (1 unless given)."""

    def __init__(self, message: str, code: int = 1) -> None:
        super().__init__(message)
        self.code = code


# Fast DDS reads its XML profiles once per process, at the first participant: the profile is needed until then.
_participant_made = False
# Whether this process's tool participants speak UDP on loopback (decided with the profile, at the first).
_loopback_udp = False


def _prepare_environment() -> Path | None:
    """Name the observer profile in this process's environment; its directory, to remove later (None: nothing)."""
    from robot_controller.ros import partition

    global _loopback_udp
    os.environ.setdefault(DISCOVERY_RANGE_ENV, "LOCALHOST")
    if _participant_made or partition.PROFILES_ENV in os.environ:
        return None
    # On this host a tool speaks UDP on loopback, never shared memory: with the tools on shared memory, a loop process
    # was seen blocked 200-330 ms in a publish while a `param set`'s participant came and went (1 run in 6 of the
    # live-gain test, braking the arm); with them on UDP, in none of 26.
    _loopback_udp = os.environ[DISCOVERY_RANGE_ENV] == "LOCALHOST"
    directory = Path(tempfile.mkdtemp(prefix="robot-controller-tools-"))
    profile = partition.write_observer_profile(directory / "observer.xml", loopback_udp=_loopback_udp)
    os.environ[partition.PROFILES_ENV] = str(profile)
    return directory


@contextlib.contextmanager
def _discovery_range_for_participant() -> Iterator[None]:
    """While a participant is made: with the loopback profile, rmw must leave transports and discovery to it (its
    LOCALHOST range would add shared memory); the process's own range is back afterwards, for its children."""
    from robot_controller.ros import partition

    if not _loopback_udp:
        yield
        return
    given = os.environ[DISCOVERY_RANGE_ENV]
    os.environ[DISCOVERY_RANGE_ENV] = partition.PEERS_DISCOVERY_RANGE
    try:
        yield
    finally:
        os.environ[DISCOVERY_RANGE_ENV] = given


def _remove_profile(directory: Path) -> None:
    """Remove the profile and its variable, so no child process inherits a path that is gone."""
    from robot_controller.ros import partition

    os.environ.pop(partition.PROFILES_ENV, None)
    shutil.rmtree(directory, ignore_errors=True)


def absolute(name: str) -> str:
    """``arm/state`` → ``/arm/state``: the tools' node lives in the root namespace."""
    return "/" + name.strip().lstrip("/")


def message_class(type_name: str) -> type:
    """``sensor_msgs/msg/JointState`` → the class, imported as ``sensor_msgs.msg.JointState``."""
    try:
        package, kind, name = type_name.split("/")
        return getattr(importlib.import_module(f"{package}.{kind}"), name)
    except (ValueError, ImportError, AttributeError) as exc:
        raise ToolError(f"type {type_name} cannot be loaded here ({exc})") from None


class Graph:
    """The tool's node on the domain, and what the tools ask of the graph through it."""

    def __init__(self, context: Any, node: Any) -> None:
        self.context = context
        self.node = node
        self.domain = context.get_domain_id()

    def topics(self) -> dict[str, list[str]]:
        """Every topic the graph shows, with its type names (hidden ones left out, as ros2cli does)."""
        from rclpy.topic_or_service_is_hidden import topic_or_service_is_hidden

        return {
            name: types for name, types in self.node.get_topic_names_and_types() if not topic_or_service_is_hidden(name)
        }

    def only_mine(self, topic: str) -> bool:
        """Whether this tool's own node is the topic's only endpoint (its /parameter_events)."""
        me = self.node.get_name()
        endpoints = self.node.get_publishers_info_by_topic(topic) + self.node.get_subscriptions_info_by_topic(topic)
        return all(info.node_name == me for info in endpoints)

    def settled_topics(
        self, *, minimum_s: float = 1.0, quiet_s: float = 0.5, maximum_s: float = 3.0
    ) -> dict[str, list[str]]:
        """The graph's topics once discovery has gone quiet (no daemon caches them for us)."""
        start = last_change = time.monotonic()
        seen = self.topics()
        while True:
            now = time.monotonic()
            if now - start >= maximum_s or (now - start >= minimum_s and now - last_change >= quiet_s):
                return {name: types for name, types in seen.items() if not self.only_mine(name)}
            time.sleep(0.05)
            current = self.topics()
            if current != seen:
                seen, last_change = current, time.monotonic()

    def wait_for_topic(self, topic: str, timeout_s: float | None = None) -> list[str]:
        """The topic's type names, once it shows in the graph; ``ToolError`` if it does not in time."""
        deadline = time.monotonic() + (DISCOVERY_TIMEOUT_S if timeout_s is None else timeout_s)
        while True:
            types = self.topics().get(topic)
            if types and not self.only_mine(topic):
                return types
            if time.monotonic() >= deadline:
                raise ToolError(f"{topic}: no such topic on domain {self.domain}")
            time.sleep(0.05)

    def call(self, srv_type: type, service: str, request: Any, *, what: str, wait_s: float | None = None) -> Any:
        """One service call with a timeout; an unanswered request is withdrawn and sent again (DDS may match the
        request path before the response path). ``what`` names the server."""
        client = self.node.create_client(srv_type, service)
        try:
            deadline = time.monotonic() + (DISCOVERY_TIMEOUT_S if wait_s is None else wait_s)
            while not client.service_is_ready():
                if time.monotonic() >= deadline:
                    raise ToolError(f"{what}: no such node on domain {self.domain} (no {service} service)")
                time.sleep(POLL_S)
            for _ in range(CALL_ATTEMPTS):
                future = client.call_async(request)
                end = time.monotonic() + CALL_ATTEMPT_S
                while not future.done() and time.monotonic() < end:
                    time.sleep(POLL_S)
                if future.done():
                    result = future.result()
                    if result is None:
                        raise ToolError(f"{what}: {service} failed ({future.exception()})")
                    return result
                client.remove_pending_request(future)
            raise ToolError(f"{what}: no answer from {service} in {CALL_ATTEMPTS * CALL_ATTEMPT_S:g} s")
        finally:
            self.node.destroy_client(client)

    def arm_joints(self, topic: str, timeout_s: float) -> tuple[list[str], Any | None]:
        """The running arm's joint names and the ``JointState`` they came from (the first on ``topic`` that names its
        joints within ``timeout_s``), else the reference arm's and None."""
        state = self._first_joint_state(topic, timeout_s)
        if state is not None:
            return list(state.name), state
        from robot_controller import resources
        from robot_controller.core.model import joint_names, load_model

        return joint_names(load_model(resources.default_urdf())), None

    def _first_joint_state(self, topic: str, timeout_s: float) -> Any | None:
        from rclpy.qos import qos_profile_sensor_data
        from sensor_msgs.msg import JointState

        heard: queue.SimpleQueue = queue.SimpleQueue()
        subscription = self.node.create_subscription(
            JointState, topic, lambda msg: heard.put(msg) if msg.name else None, qos_profile_sensor_data
        )
        try:
            return heard.get(timeout=timeout_s)
        except queue.Empty:
            return None
        finally:
            self.node.destroy_subscription(subscription)

    def send(self, publisher: Any, topic: str, msg: Any, listener: str, *, wait_s: float) -> bool:
        """Publish ``msg`` once the node ``listener`` hears ``publisher`` (:func:`wait_until_heard`); whether every
        reader acknowledged it within ``DELIVERY_TIMEOUT_S``. ``ToolError`` if it is not heard in ``wait_s``."""
        from rclpy.duration import Duration

        if not wait_until_heard(self.node, publisher, topic, listener, since=time.monotonic(), wait_s=wait_s):
            raise ToolError(f"no {listener.replace('_', ' ')} is listening on {topic} (domain {self.domain})")
        publisher.publish(msg)
        return publisher.wait_for_all_acked(Duration(seconds=DELIVERY_TIMEOUT_S))


# Discovery is two-sided and staggered: a tool sends once the readers found have all matched and nothing has changed
# for MATCH_SETTLE_S, or for UNMATCHED_SETTLE_S if some never match (readers in a partition it does not write to).
MATCH_SETTLE_S = 1.0
UNMATCHED_SETTLE_S = 1.5
#: the readers that record or draw a topic: heard by them alone, a message reached no node
TOOL_OBSERVERS = frozenset({"recorder"})


def matching(node: Any, publisher: Any, topic: str, listener: str) -> tuple[int, int] | None:
    """``(readers listed, readers matched)`` once the node ``listener`` subscribes to ``topic`` and a reader besides
    the observers has matched ``publisher``, else None (the graph lists every partition's readers; matching is per
    partition)."""
    readers = node.get_subscriptions_info_by_topic(topic)
    if not any(info.node_name == listener for info in readers):
        return None
    observers = sum(info.node_name in TOOL_OBSERVERS for info in readers)
    if observers == 0 and TOOL_OBSERVERS & set(node.get_node_names()):
        return None  # a recorder is in the graph but its reader not yet listed: it would miss the message
    matched = publisher.get_subscription_count()
    return (len(readers), matched) if matched > observers else None


def wait_until_heard(node: Any, publisher: Any, topic: str, listener: str, *, since: float, wait_s: float) -> bool:
    """Whether ``listener`` came to hear ``publisher`` on ``topic`` (:func:`matching`, settled) within ``wait_s`` of
    ``since`` (``time.monotonic()``)."""
    seen, seen_since = None, since
    while True:
        now = time.monotonic()
        found = matching(node, publisher, topic, listener)
        if found != seen:
            seen, seen_since = found, now
        elif found is not None and now - seen_since >= (MATCH_SETTLE_S if found[1] >= found[0] else UNMATCHED_SETTLE_S):
            return True
        if now - since > wait_s:
            return False
        time.sleep(0.05)


def qos(depth: int, *, best_effort: bool = False, latched: bool = False) -> Any:
    """Reliable (or best effort), volatile (or transient local), the last ``depth`` messages kept."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    reliability = ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE
    durability = DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE
    return QoSProfile(reliability=reliability, durability=durability, history=HistoryPolicy.KEEP_LAST, depth=depth)


@contextlib.contextmanager
def open_graph(tool: str) -> Iterator[Graph]:
    """A hidden node on the current ROS_DOMAIN_ID spinning in a thread, torn down on the way out. rclpy installs no
    signal handler: Ctrl-C is ``KeyboardInterrupt`` in the main thread; a second one during teardown is ignored."""
    profile_dir = _prepare_environment()
    context = node = executor = spinner = None
    try:  # from here on: a Ctrl-C while rclpy loads leaves no temporary profile behind
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.signals import SignalHandlerOptions

        context = rclpy.Context()
        # Hidden (a leading underscore), as ros2cli's own nodes: graph listings leave it out.
        name = f"_robot_controller_{''.join(c if c.isalnum() else '_' for c in tool)}_{os.getpid()}"
        with _discovery_range_for_participant():
            rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO)
            node = Node(name, context=context, start_parameter_services=False, enable_rosout=False)
        global _participant_made
        _participant_made = True  # the first participant has read the profile: remove it
        if profile_dir is not None:
            _remove_profile(profile_dir)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)

        def spin() -> None:
            try:
                executor.spin()
            except Exception:  # noqa: BLE001 - the context was shut down under it, at teardown
                pass

        spinner = threading.Thread(target=spin, name=f"{tool} executor", daemon=True)
        spinner.start()
        yield Graph(context, node)
    finally:
        with _sigint_as(signal.SIG_IGN):
            if executor is not None:
                # Jazzy's shutdown does not wait for spin(): its thread must leave before the node goes (or C++ aborts).
                executor.shutdown(timeout_sec=1.0)
                if spinner is not None:
                    spinner.join(timeout=2.0)
            if node is not None:
                node.destroy_node()
            if context is not None:
                context.try_shutdown()
            if profile_dir is not None and profile_dir.exists():  # no node was made: the next attempt writes anew
                _remove_profile(profile_dir)


@contextlib.contextmanager
def _sigint_as(handler: Any) -> Iterator[None]:
    """SIGINT handled by ``handler`` for the block (in the main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def command(name: str, *, interrupted: int = 0) -> Callable[[Callable[..., int]], Callable[..., int]]:
    """A tool's function as a command: ``ToolError`` → one line on stderr, its exit code; Ctrl-C → ``interrupted`` (0:
    the way ``echo`` and ``hz`` are meant to end), no traceback; a closed pipe (``| head``) → 0, quietly."""

    def decorate(function: Callable[..., int]) -> Callable[..., int]:
        @functools.wraps(function)
        def run(*args: Any, **kwargs: Any) -> int:
            try:
                # Ctrl-C raises KeyboardInterrupt while the command runs, even when it was started with SIGINT
                # ignored (a shell's `&` does that, and Python then keeps ignoring it): `kill -INT` must still cancel.
                with _sigint_as(signal.default_int_handler):
                    return function(*args, **kwargs)
            except ToolError as exc:
                print(f"robot-controller {name}: {exc}", file=sys.stderr, flush=True)
                return exc.code
            except KeyboardInterrupt:
                return interrupted
            except BrokenPipeError:  # the reader went away: the interpreter's last flush must not complain
                try:
                    devnull = os.open(os.devnull, os.O_WRONLY)
                    os.dup2(devnull, sys.stdout.fileno())
                    os.close(devnull)
                except (OSError, ValueError):
                    pass
                return 0

        return run

    return decorate
