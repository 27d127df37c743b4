"""The ROS node that hosts a block (``blocks.block``): each of its ports a topic as the graph spec (``blocks.spec``)
declares it, the values it writes published through gates that wait for their audience, its parameters the node's
schema's, its lines the node's log. The node's name is the graph's (``sensor_node``, ``motor_node``): the tutorial's
clients and users' config files know the nodes by it, whatever block runs inside."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from robot_controller.blocks import registry, spec
from robot_controller.ros.messages import clock_s, decode, encode, labelled_tick_s, message_class
from robot_controller.ros.qos import profile
from robot_controller.ros.stack_node import StackNode


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
            qos = profile(port.writer_qos, lockstep=self.lockstep)
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
                profile(port.qos, lockstep=self.lockstep),
            )
            if port.writer != spec.ANYONE:
                self.watch_single_publisher(port.topic, port.writer)
        period_s = block.wake_period_s()
        if period_s is not None and not self.lockstep:  # in lockstep no time passes between ticks
            self.create_timer(period_s, lambda: self.publish(self.block.step(clock_s(self), {})))
        self.publish(block.start())

    def setup(self, params: dict[str, Any]) -> None:
        self.block = registry.make(self.get_name(), params, NodeLog(self), bool(params.get("lockstep", False)))

    def check_params(self, params: dict[str, Any]) -> None:
        self.block.check_params(params)

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        self.block.set_params(params, changed)

    def deliver(self, name: str, msg: Any) -> None:
        value = decode(msg)
        self.publish(self.block.step(self.input_time_s(value), {name: value}))

    def input_time_s(self, value: Any) -> float:
        """When a value arrived, on the loop's clock: in lockstep the tick it says it was computed for (its clock
        message may come after it), else the node's clock."""
        tick_s = labelled_tick_s(getattr(value, "label", "")) if self.lockstep else None
        return clock_s(self) if tick_s is None else tick_s

    def publish(self, outputs: Mapping[str, Any]) -> None:
        for name, value in outputs.items():
            publisher, msg = self.publishers_by_port[name]
            publisher.publish(encode(value, msg))

    def finish(self) -> None:
        finish = getattr(self.block, "finish", None)
        if finish is not None:
            self.publish(finish())
