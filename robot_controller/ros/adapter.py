"""The ROS node that hosts a block (``blocks.block``): each of its ports a topic as the graph spec (``blocks.spec``)
declares it, its outputs published through gates that wait for their audience, its parameters the node's schema's
(each change validated as a whole), its lines the node's log (warnings rate-limited), a watch on who else publishes
its inputs, and its clock (``ros.ticks``). What a node serves beside its block is given to it as its
:class:`Extras`. The node's name is the graph's (``sensor_node``, ``pid_controller``, …): the tutorial's clients
and users' config files know the nodes by it, whatever block runs inside."""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Mapping
from typing import Any

from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import MultiArrayDimension

from robot_controller import parameters as cfg
from robot_controller.blocks import spec
from robot_controller.blocks.block import Block, make_block
from robot_controller.core.errors import ConfigError
from robot_controller.ros.loop_processes import leave_pid
from robot_controller.ros.messages import decode, encode, message_class
from robot_controller.ros.partition import PARTITION_ENV
from robot_controller.ros.publishing import GatedPublisher, write_publish_counts
from robot_controller.ros.qos import profile
from robot_controller.ros.ticks import clock_mode, tick_source_class

WARN_PERIOD_S = 2.0
# At the end, how long a node waits for its last messages to be acknowledged (within the cleanup's
# own limit, ros.process.CLEANUP_TIMEOUT_S): seconds, for a recorder starved on a loaded machine.
ACK_WAIT_S = 3.0
PUBLISHER_CHECK_PERIOD_S = 1.0
UNKNOWN_NODE_NAME = "_NODE_NAME_UNKNOWN_"  # what rmw reports for a writer of no known node


class Extras:
    """What a node serves beside its block, and where its ports differ from the spec's defaults: by default nothing
    (the sensor's and the drive's). A node's own extras override what they change."""

    #: rclpy ``Node`` keyword arguments (the controller serves its parameter services on a thread of its own)
    node_options: Mapping[str, Any] = {}

    def __init__(self, node: BlockNode) -> None:
        self.node = node

    def more_specs(self, values: dict[str, Any]) -> tuple[cfg.ParamSpec, ...]:
        """Parameters the node has besides its schema's, given the schema's values."""
        return ()

    def make_block(self, params: dict[str, Any], world_waits: bool) -> Block:
        return make_block(self.node.get_name(), params, self.node, world_waits)

    def topic(self, port: spec.Port) -> str:
        return port.topic

    def reader_qos(self, port: spec.Port) -> Any:
        """The QoS ``port`` is heard with from the start, or None: not heard then (the extras may listen later)."""
        return profile(port.qos, world_waits=self.node.mode.world_waits)

    def consumer(self, port: spec.Port) -> bool:
        """Whether an output in the run's partition is a consumer's (its gate waits for one), not telemetry."""
        return port.qos != "control"  # its QoS class is a reader's that acts on it

    def watched(self, port: spec.Port) -> bool:
        """Whether a second publisher of ``port`` is warned of."""
        return port.writer != spec.ANYONE

    def layout(self, port: spec.Port) -> list[tuple[str, int]] | None:
        """An array output's layout, (label, size) per dimension, laid out once: its values then fill in the data
        (and a first label they say); None: each value lays out its message."""
        return None

    def make_ticks(self, source: type) -> Any:
        node = self.node
        return source(node, node.block, node.publish, world_waits=node.mode.world_waits)

    def start(self) -> None:
        """Serve what it serves, once the ports exist and the clock started."""

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        self.node.block.set_params(params, changed)

    def finish(self) -> None:
        """Last words, after the clock's."""

    def destroy(self) -> None:
        """The node is destroyed: stop own threads and processes."""


class BlockNode(Node):
    """A node of the graph running the block its parameters choose (``blocks.block.make_block``), with the parameters of
    ``parameters.SCHEMA[node_name]`` (and its extras')."""

    def __init__(self, node_name: str, extras: type[Extras] = Extras) -> None:
        super().__init__(node_name, **extras.node_options)
        self.schema_name = node_name
        self.extras = extras(self)
        self.specs: dict[str, cfg.ParamSpec] = {}
        self._declare(cfg.SCHEMA[node_name])
        # Overrides (--params-file, -p) bypass callbacks at declaration: checked now, alone, then together.
        values = {name: param.validate(self.get_parameter(name).value) for name, param in self.specs.items()}
        more = self.extras.more_specs(values)  # what the values say the node has besides its schema's (a law's)
        self._declare(more)
        values.update({param.name: param.validate(self.get_parameter(param.name).value) for param in more})
        self.block = self.extras.make_block(values, clock_mode(values).world_waits)
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
        leave_pid(node_name)  # the paced world tells the host's waits by it
        self._ports(self.block)
        self.ticks = self.extras.make_ticks(tick_source_class(node_name, self.mode))
        self.ticks.start()
        self.extras.start()

    def _ports(self, block: Block) -> None:
        self.publishers_by_port: dict[str, tuple[Any, Any]] = {}  # port → (publisher, its reused message)
        self.laid_out: set[str] = set()  # outputs whose layout is fixed
        self.subscriptions_by_port: dict[str, Any] = {}
        for name in block.outputs:
            port = spec.port(name)
            msg_type = message_class(port.msg_type)
            qos = profile(port.writer_qos, world_waits=self.mode.world_waits)
            if port.partition:
                kept = port in spec.recorded_ports(self.mode.world_waits)
                consumer = self.extras.consumer(port)
                publisher = self.gated_publisher(msg_type, port.topic, consumer=consumer, qos=qos, kept=kept)
            else:
                publisher = self.create_publisher(msg_type, port.topic, qos)
            msg = msg_type()
            if layout := self.extras.layout(port):
                msg.layout.dim = [MultiArrayDimension(label=label, size=size, stride=size) for label, size in layout]
                self.laid_out.add(name)
            self.publishers_by_port[name] = (publisher, msg)
        for name in block.inputs:
            port = spec.port(name)
            qos = self.extras.reader_qos(port)
            if qos is not None:
                self.subscriptions_by_port[name] = self.hear(port, qos)
            if self.extras.watched(port):
                self.watch_single_publisher(port.topic, port.writer)

    def hear(self, port: spec.Port, qos: Any) -> Any:
        return self.create_subscription(
            message_class(port.msg_type),
            self.extras.topic(port),
            lambda msg, name=port.name: self.ticks.take(name, decode(msg)),
            qos,
        )

    def publish(self, outputs: Mapping[str, Any]) -> None:
        for name, value in outputs.items():
            publisher, msg = self.publishers_by_port[name]
            if name in self.laid_out:
                msg.data = value.data.tolist()
                if value.label:
                    msg.layout.dim[0].label = value.label
            else:
                encode(value, msg)
            publisher.publish(msg)

    def finish(self) -> None:
        """Last words, once the executor has stopped."""
        self.ticks.finish()
        self.extras.finish()

    def destroy_node(self) -> None:
        self.extras.destroy()
        if close := getattr(self.block, "close", None):  # a block holding more than memory (a camera's GL context)
            close()
        super().destroy_node()

    def _declare(self, specs: tuple[cfg.ParamSpec, ...]) -> None:
        for param in specs:
            descriptor = ParameterDescriptor(
                description=param.describe(),
                read_only=param.read_only,
                # numbers: accept 50 as well as 50.0, and a scalar for a per-joint list
                dynamic_typing=param.kind is float,
            )
            self.declare_parameter(param.name, param.default_value(), descriptor)
            self.specs[param.name] = param

    def _validated(self, values: dict[str, Any]) -> dict[str, Any]:
        try:
            out = {name: self.specs[name].validate(value) for name, value in values.items()}
            self.block.check_params(out)
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
        self.extras.apply_params(self.params, changed)
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

    def gated_publisher(
        self, msg_type: Any, topic: str, *, consumer: bool = True, qos: Any = None, kept: bool = True
    ) -> GatedPublisher:
        world_waits = self.mode.world_waits
        gated = GatedPublisher(self, msg_type, topic, world_waits=world_waits, consumer=consumer, qos=qos, kept=kept)
        self._gated_publishers.append(gated)
        return gated

    def wait_until_acknowledged(self, timeout_s: float = ACK_WAIT_S) -> None:
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
            self.warn(f"publishers{topic}", f"{topic} has publishers other than {expected}: {others}; " + consequence)

    # The block's log (``blocks.block.Log``): the node's, its warnings rate-limited per key.
    def info(self, message: str) -> None:
        self.get_logger().info(message)

    def warning(self, message: str) -> None:
        self.get_logger().warning(message)

    def error(self, message: str) -> None:
        self.get_logger().error(message)

    def warn(self, key: str, message: str) -> None:
        now = time.monotonic()
        last, suppressed = self._warned_at.get(key, (-float("inf"), 0))
        if now - last >= WARN_PERIOD_S:
            extra = f" ({suppressed} more since the last warning)" if suppressed else ""
            self.get_logger().warning(message + extra)
            self._warned_at[key] = (now, 0)
        else:
            self._warned_at[key] = (last, suppressed + 1)
