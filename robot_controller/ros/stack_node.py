"""What every node here shares: parameters declared from the schema with
their defaults from ``config/stack.yaml``, validation on set, rate-limited
warnings, QoS, and the ``main`` skeleton of ros2/examples."""
from __future__ import annotations

import copy
import faulthandler
import gc
from collections import deque
import json
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from typing import Any

import rclpy
from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.executors import Executor, ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions
from rclpy.time import Time
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.ros.partition import PARTITION_ENV
from robot_controller.core.errors import ConfigError

# Reliable, volatile, keep-last: compatible with the tutorial's default-QoS
# publishers and subscribers, so its nodes talk to ours unchanged. Depth 1000
# (10 s of a 100 Hz topic, a few hundred kB) lets a reader that falls behind
# (the recorder, below the loop) catch up without losing samples.
CONTROL_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE,
                         history=HistoryPolicy.KEEP_LAST, depth=1000)

# What a controller, a drive or an encoder acts on: the newest message only.
# A node that was paused must not work through a backlog of stale readings or
# torques when it resumes (and in lockstep there is one message in flight).
LATEST_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE,
                        history=HistoryPolicy.KEEP_LAST, depth=1)
# A state, not an event (the motor's brake request): a reader that starts late,
# such as a respawned simulator, gets the current value at once.
LATCHED_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                         history=HistoryPolicy.KEEP_LAST, depth=1)
# /clock in lockstep: a reader that matches late (the controller pairs each
# reading with its tick's /clock, reading it with LATCHED_QOS) still gets the latest tick.
CLOCK_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                       history=HistoryPolicy.KEEP_LAST, depth=1000)
# /estop: volatile readers, so a plain `ros2 topic pub /estop` (volatile) matches too;
# the e-stop is latched by the nodes that obey it, not by DDS.
ESTOP_QOS = LATEST_QOS

WARN_PERIOD_S = 2.0
PUBLISHER_CHECK_PERIOD_S = 1.0
UNKNOWN_NODE_NAME = "_NODE_NAME_UNKNOWN_"  # what rmw reports for a writer of no known node


class StackNode(Node):
    """A node whose parameters are those of ``config.SCHEMA[schema_name]``.

    Subclasses implement :meth:`check_params` (refuse a combination, raising
    ``ConfigError``) and :meth:`apply_params` (take new values while running).
    """

    def __init__(self, schema_name: str, **kwargs: Any) -> None:
        super().__init__(schema_name, **kwargs)
        self.schema_name = schema_name
        defaults = cfg.read_params_file(resources.stack_yaml())[schema_name]
        for spec in cfg.SCHEMA[schema_name]:
            descriptor = ParameterDescriptor(
                description=spec.describe(), read_only=spec.read_only,
                # numbers: accept 50 as well as 50.0, and a scalar for a per-joint list
                dynamic_typing=spec.kind in (float, "floats"))
            self.declare_parameter(spec.name, defaults[spec.name], descriptor)
        # Overrides from --params-file / -p bypass callbacks at declaration: check them now.
        self.params = self._validated({spec.name: self.get_parameter(spec.name).value
                                       for spec in cfg.SCHEMA[schema_name]})
        self._warned_at: dict[str, tuple[float, int]] = {}
        self.gated_publishers: list[GatedPublisher] = []
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.add_post_set_parameters_callback(self._post_set_parameters)

    # --- parameters ---------------------------------------------------------

    def finish(self) -> None:
        """Last words, once the executor has stopped: stop the node's own threads and
        publish what is pending, so that the publish counts written next are final."""

    def check_params(self, params: dict[str, Any]) -> None:
        """Raise ``ConfigError`` if this combination of values cannot run."""

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        """Take the new values (already validated) while running."""

    def _validated(self, values: dict[str, Any]) -> dict[str, Any]:
        """The values checked one by one and together; any failure is a ``ConfigError``
        with its reason (a design that does not solve, a rate the physics cannot keep)."""
        try:
            out = {name: cfg.spec_of(self.schema_name, name).validate(value) for name, value in values.items()}
            self.check_params(out)
        except ConfigError:
            raise
        except Exception as exc:  # noqa: BLE001 - whatever the check raised, the value is refused, not the node
            raise ConfigError(f"{type(exc).__name__}: {exc}") from exc
        return out

    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        candidate = dict(self.params)
        for parameter in parameters:
            if parameter.name not in candidate:
                continue  # use_sim_time and other built-ins
            if parameter.type_ == Parameter.Type.NOT_SET:
                return SetParametersResult(successful=False, reason=f"{parameter.name}: cannot be undeclared")
            candidate[parameter.name] = parameter.value
        try:
            self._pending = self._validated(candidate)
        except ConfigError as exc:
            self.get_logger().warning(f"refused parameter change: {exc}")
            return SetParametersResult(successful=False, reason=str(exc))
        return SetParametersResult(successful=True)

    def _post_set_parameters(self, parameters: list[Parameter]) -> None:
        changed = {p.name for p in parameters if p.name in self.params}
        if not changed:
            return
        self.params = self._pending
        self.apply_params(self.params, changed)
        self.get_logger().info("parameters changed: " + ", ".join(f"{n}={self.params[n]}" for n in sorted(changed)))

    # --- helpers ------------------------------------------------------------

    def now_s(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def watch_single_publisher(self, topic: str, expected: str) -> None:
        """Warn, naming them, whenever ``topic`` has publishers besides the node ``expected``.

        rclpy (Jazzy) gives no publisher identity with a message, so a node
        cannot drop another publisher's messages itself. When the launcher
        started it, the run's loop topics are in a DDS partition of their own
        (``dds_partition``) and a publisher from outside the run is never
        heard; the warning says so. A node started by hand is in the default
        partition: there it hears every publisher, and the warning says that.
        Plausibility checks (stamps, sizes, finiteness, effort limits) apply to
        every message either way.
        """
        if not hasattr(self, "_watched_topics"):
            self._watched_topics: dict[str, str] = {}
            self.create_timer(PUBLISHER_CHECK_PERIOD_S, self._check_publishers,
                              clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._watched_topics[topic] = expected

    def _check_publishers(self) -> None:
        partition = os.environ.get(PARTITION_ENV, "")
        for topic, expected in self._watched_topics.items():
            # A writer whose node is not discovered yet (or that is no ROS node) has no name.
            others = sorted(info.node_name.replace(UNKNOWN_NODE_NAME, "<unnamed>")
                            for info in self.get_publishers_info_by_topic(topic))
            if expected in others:
                others.remove(expected)
            if not others:
                continue
            if partition:
                consequence = (f"not heard if started outside this run (its loop topics are in DDS partition "
                               f"{partition})")
            else:
                consequence = "obeyed like it: this node is not in a run's partition, so it hears every publisher"
            self.warn_throttled(f"publishers{topic}", f"{topic} has publishers other than {expected}: {others}; "
                                + consequence)

    def warn_throttled(self, key: str, message: str) -> None:
        """Warn at most once per ``WARN_PERIOD_S`` per ``key``, counting what was suppressed."""
        now = time.monotonic()
        last, suppressed = self._warned_at.get(key, (-float("inf"), 0))
        if now - last >= WARN_PERIOD_S:
            extra = f" ({suppressed} more since the last warning)" if suppressed else ""
            self.get_logger().warning(message + extra)
            self._warned_at[key] = (now, 0)
        else:
            self._warned_at[key] = (last, suppressed + 1)


# Nodes that only watch (the recorder, a viewer) do not count as consumers.
RECORDER_NODE = "recorder"
OBSERVER_NODES = frozenset({RECORDER_NODE})

# Set by the launcher when a recorder runs: every publisher then also waits
# for the recorder, so the bag holds every message the loop ever sent.
RECORDED_ENV = "ROBOT_CONTROLLER_RECORDED"
# Where each node writes how many messages it published, per topic, when it
# stops (the launcher compares them with the bag).
COUNTS_DIR_ENV = "ROBOT_CONTROLLER_COUNTS_DIR"
# The simulator keeps the arm's state in this file (memory-mapped): a simulator
# that is respawned finds the arm where it was, as a restarted drive does.
WORLD_STATE_ENV = "ROBOT_CONTROLLER_WORLD_STATE"


def recorded() -> bool:
    return os.environ.get(RECORDED_ENV, "") == "1"


# Discovery is two-sided: a writer can see a reader before the reader knows
# the writer, and the reader drops what arrives in between. A reader counts
# as matched once it has been seen for this long.
MATCH_SETTLE_S = 0.25


def has_consumer(node: Node, topic: str) -> bool:
    """Whether a node other than an observer subscribes to ``topic``."""
    return any(info.node_name not in OBSERVER_NODES for info in node.get_subscriptions_info_by_topic(topic))


def has_recorder(node: Node, topic: str) -> bool:
    return any(info.node_name == RECORDER_NODE for info in node.get_subscriptions_info_by_topic(topic))


class ConsumerWatch:
    """``ready()`` once the audience of ``topic`` has been seen for ``MATCH_SETTLE_S`` (wall time).

    The audience is a consumer (unless ``consumer`` is False) and, when the
    run is recorded, the recorder.
    """

    def __init__(self, node: Node, topic: str, *, consumer: bool = True) -> None:
        self.node, self.topic = node, topic
        self.consumer = consumer
        self.recorder = recorded()
        self.seen_since: float | None = None

    def present(self) -> bool:
        return ((not self.consumer or has_consumer(self.node, self.topic))
                and (not self.recorder or has_recorder(self.node, self.topic)))

    def ready(self) -> bool:
        if not self.present():
            self.seen_since = None
            return False
        now = time.monotonic()
        if self.seen_since is None:
            self.seen_since = now
        return now - self.seen_since >= MATCH_SETTLE_S


MAX_HELD = 1000  # messages a gate holds at most (10 s of a 100 Hz topic)


class GatedPublisher:
    """Holds what is published until its audience (a consumer and, when the run
    is recorded, the recorder) has matched, then publishes; counts what it published.

    In lockstep nothing is ever re-sent (a re-sent effort would double a
    tick), so the first message must not go out before anyone listens; in
    wall-clock mode only the newest held message is worth sending.
    ``consumer=False``: telemetry, whose only audience is the recorder.
    """

    def __init__(self, node: StackNode, msg_type: Any, topic: str, *, consumer: bool = True,
                 qos: QoSProfile = None) -> None:
        self.node, self.topic = node, topic
        self.publisher = node.create_publisher(msg_type, topic, qos or CONTROL_QOS)
        self.watch = ConsumerWatch(node, topic, consumer=consumer)
        self.open = not consumer and not self.watch.recorder
        # Held until open: every message for telemetry and in lockstep (each is a
        # tick, and the bag must hold them all), only the newest for a wall-clock
        # consumer (an old reading or torque is worth nothing).
        self.hold_all = not consumer or bool(node.params.get("lockstep", False))
        self.count = 0
        self.pending: deque[Any] = deque(maxlen=MAX_HELD if self.hold_all else 1)
        self._poll = None
        if not self.open:
            self._poll = node.create_timer(0.05, self._check, clock=Clock(clock_type=ClockType.STEADY_TIME))
        node.gated_publishers.append(self)

    def publish(self, msg: Any) -> None:
        if self.open:
            self.publisher.publish(msg)
            self.count += 1
        else:
            # Held for the poll timer to flush: publish() may run on a thread of
            # the node's own (the simulator's pacing), the timer on the executor.
            self.pending.append(copy.deepcopy(msg))

    def _check(self) -> None:
        if self.open or not self.watch.ready():
            return
        self.open = True
        self.node.destroy_timer(self._poll)
        self.node.get_logger().debug(f"{self.topic}: audience matched, publishing")
        while self.pending:  # popleft, not iteration: another thread may still append
            self.publisher.publish(self.pending.popleft())
            self.count += 1


def write_publish_counts(nodes: list[StackNode]) -> None:
    """Each node's published-message counts, for the launcher to check the bag against."""
    counts_dir = os.environ.get(COUNTS_DIR_ENV, "")
    if not counts_dir:
        return
    for node in nodes:
        counts: dict[str, int] = {}
        for gated in node.gated_publishers:
            counts[gated.topic] = counts.get(gated.topic, 0) + gated.count
        try:
            with open(os.path.join(counts_dir, f"{node.schema_name}.json"), "w") as f:
                json.dump(counts, f)
        except OSError:
            pass


def stamp_to_s(stamp: Any) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def s_to_stamp(time_s: float) -> Any:
    """A ``builtin_interfaces/Time`` for ``time_s`` seconds (to the nearest ns)."""
    return Time(nanoseconds=round(time_s * 1e9)).to_msg()


# Cleanup that takes longer than this is stuck (rclpy's destroy_node can wait
# forever on a handle after an external shutdown): exit anyway.
CLEANUP_TIMEOUT_S = 3.0


def exit_after_cleanup_timeout(code_ref: list[int]) -> threading.Timer:
    """Arm a timer that hard-exits the process if cleanup hangs; cancel it when done."""
    timer = threading.Timer(CLEANUP_TIMEOUT_S, lambda: os._exit(code_ref[0]))
    timer.daemon = True
    timer.start()
    # The timer needs the GIL; a call stuck in C that holds it (seen once in a
    # DDS teardown) would stop it. faulthandler's watchdog is a C thread: it
    # prints where every thread is stuck, then exits (code 1).
    faulthandler.dump_traceback_later(CLEANUP_TIMEOUT_S + 1.0, exit=True)
    return timer


def shutting_down(within_s: float = 0.5) -> bool:
    """Whether the context is (about to be) shut down: the signal handler's
    shutdown can lag the error it caused in the executor by a moment."""
    deadline = time.monotonic() + within_s
    while rclpy.ok():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.01)
    return True


def make_executor(context: rclpy.Context | None = None) -> Executor:
    """rclpy's EventsExecutor: it waits on events instead of rebuilding a wait
    set for every callback, which more than doubles the lockstep speed
    (measured: real-time factor 2.4 against 1.1). ``ROBOT_CONTROLLER_EXECUTOR=single``
    picks the SingleThreadedExecutor instead."""
    if os.environ.get("ROBOT_CONTROLLER_EXECUTOR", "events") == "events":
        from rclpy.experimental import EventsExecutor

        return EventsExecutor(context=context)
    return SingleThreadedExecutor(context=context)


_stop_requested = threading.Event()


def init_with_own_signals(args: list[str] | None) -> None:
    """rclpy.init, with SIGINT/SIGTERM only asking the spin loop to stop.

    rclpy's own handling raises KeyboardInterrupt wherever Python happens to
    be, inside a callback as often as not; here a signal ends the loop
    between callbacks and cleanup runs in order.
    """
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: _stop_requested.set())


def spin(executor: Executor) -> None:
    """Spin until a stop signal or shutdown. A loop of spin_once: the
    EventsExecutor's own spin() never returns after a shutdown in this rclpy."""
    while not _stop_requested.is_set() and rclpy.ok():
        executor.spin_once(timeout_sec=0.1)


def run(node_factories: Callable[[], Node] | list[Callable[[], Node]], args: list[str] | None = None) -> int:
    """Init, build the node(s) on one executor, spin until Ctrl-C or shutdown,
    clean up; a bad parameter exits 2 with its reason."""
    factories = node_factories if isinstance(node_factories, list) else [node_factories]
    init_with_own_signals(args)
    nodes: list[Node] = []
    code = [0]
    executor = make_executor()
    try:
        for factory in factories:
            nodes.append(factory())
            executor.add_node(nodes[-1])
        # Everything built so far lives as long as the nodes: keep it out of
        # every later full collection, which would otherwise pause the loop.
        gc.freeze()
        spin(executor)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RuntimeError:
        # A signal can shut the context down while a callback is taking a
        # message; that is a normal stop, anything else is not.
        if not shutting_down():
            raise
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr, flush=True)
        code[0] = 2
    finally:
        guard = exit_after_cleanup_timeout(code)
        executor.shutdown(timeout_sec=1.0)
        for node in nodes:
            if isinstance(node, StackNode):
                node.finish()
        write_publish_counts([n for n in nodes if isinstance(n, StackNode)])  # final: nothing publishes now
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
        guard.cancel()
        faulthandler.cancel_dump_traceback_later()
    return code[0]
