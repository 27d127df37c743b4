"""The ROS node that hosts a block (``blocks.block``): each of its ports a topic as the graph spec (``blocks.spec``)
declares it, the values it writes published through gates that wait for their audience, its parameters the node's
schema's, its lines the node's log, and its clock (``ros.ticks``) chosen once from its parameters. What a node serves
beside its block (an action server, parameter services on a thread, a designer process) is given to it as its
:class:`Extras`. The node's name is the graph's (``sensor_node``, ``pid_controller``, …): the tutorial's clients and
users' config files know the nodes by it, whatever block runs inside."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from robot_controller import parameters as cfg
from robot_controller.blocks import registry, spec
from robot_controller.blocks.block import Block
from robot_controller.ros.messages import decode, encode, message_class
from robot_controller.ros.qos import profile
from robot_controller.ros.stack_node import StackNode
from robot_controller.ros.ticks import clock_mode, tick_source_class


class NodeLog:
    """A block's lines in its node's log: warnings rate-limited per key, or said every time, and errors."""

    def __init__(self, node: StackNode) -> None:
        self.node = node

    def info(self, message: str) -> None:
        self.node.get_logger().info(message)

    def warn(self, key: str, message: str) -> None:
        self.node.warn_throttled(key, message)

    def warning(self, message: str) -> None:
        self.node.get_logger().warning(message)

    def error(self, message: str) -> None:
        self.node.get_logger().error(message)


class Extras:
    """What a node serves beside its block, and where its ports differ from the spec's defaults: by default nothing
    (the sensor's and the drive's). A node's own extras override what they change; they hold the node, never the
    other way round."""

    #: rclpy ``Node`` keyword arguments (the controller serves its parameter services on a thread of its own)
    node_options: Mapping[str, Any] = {}

    def __init__(self, node: BlockNode) -> None:
        self.node = node

    def more_specs(self, values: dict[str, Any]) -> tuple[cfg.ParamSpec, ...]:
        """Parameters the node has besides its schema's, given the schema's values."""
        return ()

    def make_block(self, params: dict[str, Any], world_waits: bool) -> Block:
        return registry.make(self.node.get_name(), params, NodeLog(self.node), world_waits)

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

    def message(self, port: spec.Port) -> Any:
        """The reused message of an output, laid out once."""
        return message_class(port.msg_type)()

    def write(self, name: str, value: Any, msg: Any) -> Any:
        """``value`` of output ``name`` written into its message."""
        return encode(value, msg)

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


class BlockNode(StackNode):
    """A node of the graph running the block its parameters choose (``blocks.registry``), stepped by its clock."""

    def __init__(self, node_name: str, extras: type[Extras] = Extras) -> None:
        self.extras = extras(self)  # before the node's parameters: they may declare more (a law's)
        super().__init__(node_name, **extras.node_options)
        block = self.block
        self.publishers_by_port: dict[str, tuple[Any, Any]] = {}  # port → (publisher, its reused message)
        self.subscriptions_by_port: dict[str, Any] = {}
        for name in block.outputs:
            port = spec.port(name)
            msg_type = message_class(port.msg_type)
            qos = profile(port.writer_qos, world_waits=self.mode.world_waits)
            if port.partition:
                publisher = self.gated_publisher(msg_type, port.topic, consumer=self.extras.consumer(port), qos=qos)
            else:
                publisher = self.create_publisher(msg_type, port.topic, qos)
            self.publishers_by_port[name] = (publisher, self.extras.message(port))
        for name in block.inputs:
            port = spec.port(name)
            qos = self.extras.reader_qos(port)
            if qos is not None:
                self.subscriptions_by_port[name] = self.hear(port, qos)
            if self.extras.watched(port):
                self.watch_single_publisher(port.topic, port.writer)
        self.ticks = self.extras.make_ticks(tick_source_class(node_name, self.mode))
        self.ticks.start()
        self.extras.start()

    def more_specs(self, values: dict[str, Any]) -> tuple[cfg.ParamSpec, ...]:
        return self.extras.more_specs(values)

    def setup(self, params: dict[str, Any]) -> None:
        self.block = self.extras.make_block(params, clock_mode(params).world_waits)

    def check_params(self, params: dict[str, Any]) -> None:
        self.block.check_params(params)

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        self.extras.apply_params(params, changed)

    def hear(self, port: spec.Port, qos: Any) -> Any:
        """A subscription handing ``port``'s values to the node's clock."""
        return self.create_subscription(
            message_class(port.msg_type),
            self.extras.topic(port),
            lambda msg, name=port.name: self.ticks.take(name, decode(msg)),
            qos,
        )

    def publish(self, outputs: Mapping[str, Any]) -> None:
        for name, value in outputs.items():
            publisher, msg = self.publishers_by_port[name]
            publisher.publish(self.extras.write(name, value, msg))

    def finish(self) -> None:
        self.ticks.finish()
        self.extras.finish()

    def destroy_node(self) -> None:
        self.extras.destroy()
        super().destroy_node()
