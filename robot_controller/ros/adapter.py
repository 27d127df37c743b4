"""The ROS node that hosts a block (``blocks.block``): each of its ports a topic as the graph spec (``blocks.spec``)
declares it, the values it writes published through gates that wait for their audience, its parameters the node's
schema's, its lines the node's log. The node's name is the graph's (``sensor_node``, ``motor_node``): the tutorial's
clients and users' config files know the nodes by it, whatever block runs inside."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from robot_controller.blocks import registry, spec
from robot_controller.ros.messages import decode, encode, message_class
from robot_controller.ros.qos import profile
from robot_controller.ros.stack_node import StackNode
from robot_controller.ros.ticks import clock_mode, tick_source_class


class NodeLog:
    """A block's lines in its node's log, warnings rate-limited per key."""

    def __init__(self, node: StackNode) -> None:
        self.node = node

    def info(self, message: str) -> None:
        self.node.get_logger().info(message)

    def warn(self, key: str, message: str) -> None:
        self.node.warn_throttled(key, message)


class BlockNode(StackNode):
    """A node of the graph running the block its parameters choose (``blocks.registry``)."""

    def __init__(self, node_name: str) -> None:
        super().__init__(node_name)
        block = self.block
        self.publishers_by_port: dict[str, tuple[Any, Any]] = {}  # port → (publisher, its reused message)
        for name in block.outputs:
            port = spec.port(name)
            msg_type = message_class(port.msg_type)
            qos = profile(port.writer_qos, world_waits=self.mode.world_waits)
            if port.partition:
                # A consumer acts on it (its QoS class is a reader's that acts); telemetry's reader only watches.
                publisher = self.gated_publisher(msg_type, port.topic, consumer=port.qos != "control", qos=qos)
            else:
                publisher = self.create_publisher(msg_type, port.topic, qos)
            self.publishers_by_port[name] = (publisher, msg_type())
        for name in block.inputs:
            port = spec.port(name)
            self.create_subscription(
                message_class(port.msg_type),
                port.topic,
                lambda msg, name=name: self.deliver(name, msg),
                profile(port.qos, world_waits=self.mode.world_waits),
            )
            if port.writer != spec.ANYONE:
                self.watch_single_publisher(port.topic, port.writer)
        self.ticks.start()

    def setup(self, params: dict[str, Any]) -> None:
        world_waits = clock_mode(params).world_waits
        self.block = registry.make(self.get_name(), params, NodeLog(self), world_waits)
        self.ticks = tick_source_class(self.get_name(), clock_mode(params))(
            self, self.block, self.publish, world_waits=world_waits
        )

    def check_params(self, params: dict[str, Any]) -> None:
        self.block.check_params(params)

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        self.block.set_params(params, changed)

    def deliver(self, name: str, msg: Any) -> None:
        self.ticks.take(name, decode(msg))

    def publish(self, outputs: Mapping[str, Any]) -> None:
        for name, value in outputs.items():
            publisher, msg = self.publishers_by_port[name]
            publisher.publish(encode(value, msg))

    def finish(self) -> None:
        self.ticks.finish()
