"""The node every stack node is: its parameters declared from the schema, each change
validated as a whole before it is accepted, rate-limited warnings, a watch on who
else publishes its inputs, and the gated publishers it owns (``publishing``)."""

from __future__ import annotations

import os
import threading
import time
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.parameter import Parameter

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError
from robot_controller.ros.loop_processes import leave_pid
from robot_controller.ros.partition import PARTITION_ENV
from robot_controller.ros.publishing import COUNTS_DIR_ENV, GatedPublisher, write_publish_counts
from robot_controller.ros.ticks import clock_mode

WARN_PERIOD_S = 2.0
# At the end, how long a node waits for its last messages to be acknowledged (within the cleanup's
# own limit, ros.process.CLEANUP_TIMEOUT_S): seconds, for a recorder starved on a loaded machine.
ACK_WAIT_S = 3.0
PUBLISHER_CHECK_PERIOD_S = 1.0
UNKNOWN_NODE_NAME = "_NODE_NAME_UNKNOWN_"  # what rmw reports for a writer of no known node


class StackNode(Node):
    """A node with the parameters of ``parameters.SCHEMA[schema_name]`` (and :meth:`more_specs`'s)."""

    def __init__(self, schema_name: str, **kwargs: Any) -> None:
        super().__init__(schema_name, **kwargs)
        self.schema_name = schema_name
        self.specs: dict[str, cfg.ParamSpec] = {}
        self._declare(cfg.SCHEMA[schema_name])
        # Overrides (--params-file, -p) bypass callbacks at declaration: checked now, alone, then together.
        values = {name: spec.validate(self.get_parameter(name).value) for name, spec in self.specs.items()}
        more = self.more_specs(values)  # what the values say the node has besides its schema's
        self._declare(more)
        values.update({spec.name: spec.validate(self.get_parameter(spec.name).value) for spec in more})
        self.setup(values)
        self.params = self._validated(values)
        # Read-only: fixed for the node's life, as its gates and its clock need it.
        self.mode = clock_mode(self.params)
        self._reports: dict[str, str] = {}  # name → description of what the node reports there
        self._reporting: int | None = None  # the thread reporting (the parameter services may run on another)
        self._pending: dict[str, Any] | None = None  # validated by the on-set callback, applied after it
        self._warned_at: dict[str, tuple[float, int]] = {}
        self._gated_publishers: list[GatedPublisher] = []
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.add_post_set_parameters_callback(self._post_set_parameters)
        leave_pid(os.environ.get(COUNTS_DIR_ENV, ""), schema_name)  # the paced world tells the host's waits by it

    def _declare(self, specs: tuple[cfg.ParamSpec, ...]) -> None:
        for spec in specs:
            descriptor = ParameterDescriptor(
                description=spec.describe(),
                read_only=spec.read_only,
                # numbers: accept 50 as well as 50.0, and a scalar for a per-joint list
                dynamic_typing=spec.kind is float,
            )
            self.declare_parameter(spec.name, spec.default_value(), descriptor)
            self.specs[spec.name] = spec

    def more_specs(self, values: dict[str, Any]) -> tuple[cfg.ParamSpec, ...]:
        """Parameters the node has besides its schema's, given the schema's values (a law's ``law.*``)."""
        return ()

    def finish(self) -> None:
        """Last words, once the executor has stopped: stop own threads, publish what is pending."""

    def setup(self, params: dict[str, Any]) -> None:
        """Learn what the checks need from the read-only parameters, before :meth:`check_params` runs."""

    def check_params(self, params: dict[str, Any]) -> None:
        """Raise ``ConfigError`` if this combination of values cannot run."""

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        """Take the new values (already validated) while running."""

    def _validated(self, values: dict[str, Any]) -> dict[str, Any]:
        """The values checked one by one and together; any failure is a ``ConfigError`` with its reason."""
        try:
            out = {name: self.specs[name].validate(value) for name, value in values.items()}
            self.check_params(out)
        except ConfigError:
            raise
        except Exception as exc:  # noqa: BLE001 - whatever the check raised, the value is refused, not the node
            raise ConfigError(f"{type(exc).__name__}: {exc}") from exc
        return out

    def set_parameters_atomically(self, parameter_list: list[Parameter]) -> SetParametersResult:
        """rclpy's (the parameter services call it), but a read-only parameter's refusal says why and is logged."""
        for parameter in parameter_list:
            spec = self.specs.get(parameter.name)
            if spec is not None and spec.read_only:
                reason = f"{parameter.name}: {spec.refusal}"
                self.get_logger().warning(f"refused parameter change: {reason}")
                return SetParametersResult(successful=False, reason=reason)
        return super().set_parameters_atomically(parameter_list)

    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        candidate = dict(self.params)
        for parameter in parameters:
            if parameter.name in self._reports and self._reporting != threading.get_ident():
                reason = f"{parameter.name}: reported by the node, not settable ({self._reports[parameter.name]})"
                return SetParametersResult(successful=False, reason=reason)
            if parameter.name not in candidate:
                continue  # use_sim_time and other built-ins
            if parameter.type_ == Parameter.Type.NOT_SET:
                return SetParametersResult(successful=False, reason=f"{parameter.name}: cannot be undeclared")
            candidate[parameter.name] = parameter.value
        if not any(parameter.name in self.params for parameter in parameters):
            return SetParametersResult(successful=True)  # a report or a built-in: nothing of the node's to check
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

    def report(self, name: str, value: str, description: str = "") -> None:
        """Show ``value`` as the read-only string parameter ``name`` (the gains in force, say)."""
        self._reporting = threading.get_ident()  # declaring and setting both pass through the on-set callback
        try:
            if name in self._reports:
                self.set_parameters([Parameter(name, Parameter.Type.STRING, value)])
            else:
                self._reports[name] = description
                self.declare_parameter(name, value, ParameterDescriptor(description=description))
        finally:
            self._reporting = None

    def gated_publisher(self, msg_type: Any, topic: str, *, consumer: bool = True, qos: Any = None) -> GatedPublisher:
        """A publisher that holds its messages until its audience has matched (``ros.publishing``)."""
        gated = GatedPublisher(self, msg_type, topic, world_waits=self.mode.world_waits, consumer=consumer, qos=qos)
        self._gated_publishers.append(gated)
        return gated

    def wait_until_acknowledged(self, timeout_s: float = ACK_WAIT_S) -> None:
        """Wait (at most ``timeout_s`` in all) until the readers have acknowledged what the gates published."""
        deadline = time.monotonic() + timeout_s
        for gated in self._gated_publishers:
            left_s = deadline - time.monotonic()
            if left_s <= 0 or not gated.publisher.wait_for_all_acked(Duration(nanoseconds=int(left_s * 1e9))):
                # Said, so that a bag that misses the last messages has its reason in the log.
                self.get_logger().warning(
                    f"{gated.publisher.topic_name}: not every reader acknowledged the last messages "
                    f"within {timeout_s:g} s of the stop"
                )
                return

    def write_publish_counts(self) -> None:
        """Write how many messages the node's gates published, per topic, for the launcher."""
        write_publish_counts(self.schema_name, self._gated_publishers)

    def watch_single_publisher(self, topic: str, expected: str) -> None:
        """Warn, naming them, whenever ``topic`` has publishers besides the node ``expected``."""
        if not hasattr(self, "_watched_topics"):
            self._watched_topics: dict[str, str] = {}
            self.create_timer(
                PUBLISHER_CHECK_PERIOD_S, self._check_publishers, clock=Clock(clock_type=ClockType.STEADY_TIME)
            )
        self._watched_topics[topic] = expected

    def _check_publishers(self) -> None:
        partition = os.environ.get(PARTITION_ENV, "")
        for topic, expected in self._watched_topics.items():
            # A writer whose node is not discovered yet (or that is no ROS node) has no name.
            others = sorted(
                info.node_name.replace(UNKNOWN_NODE_NAME, "<unnamed>")
                for info in self.get_publishers_info_by_topic(topic)
            )
            if expected in others:
                others.remove(expected)
            if not others:
                continue
            # The expected name again: a second node of that name (another run on this domain, or a stray copy).
            others = [f"{name} (a second one)" if name == expected else name for name in others]
            if partition:
                consequence = (
                    f"not heard if started outside this run (its loop topics are in DDS partition {partition})"
                )
            else:
                consequence = "obeyed like it: this node is not in a run's partition, so it hears every publisher"
            self.warn_throttled(
                f"publishers{topic}", f"{topic} has publishers other than {expected}: {others}; " + consequence
            )

    def drop(self, topic: str, reason: str) -> None:
        """Say (rate-limited) that a message on ``topic`` is dropped, and why (its check's ``reason``)."""
        self.warn_throttled(topic, f"{topic} dropped: {reason}")

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
