"""The controller's node (``pid_controller``, the name the tutorial and users' files know): it hosts the controller
block (``blocks.controller``), its ports the graph spec's topics, stepped by the clock chosen once at start
(``ros.controller_ticks``); its parameter services answer on a thread of their own (``live_gains``), a change's law
designed in a process of its own (``designer``). Every decision about torque is the block's core's."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64MultiArray, MultiArrayDimension

from robot_controller import parameters as cfg
from robot_controller.blocks import registry, spec
from robot_controller.blocks.controller import Controller
from robot_controller.core.laws import parameters as law_parameters
from robot_controller.nodes.pid_controller import live_gains
from robot_controller.nodes.pid_controller.designer import Designer
from robot_controller.parameters import law_params
from robot_controller.parameters.builders import arm_model
from robot_controller.ros.loop_processes import thread_kept_s
from robot_controller.ros.messages import clock_s, decode, stamp_command
from robot_controller.ros.process import LAW_FAULT_FILE, request_exit, run
from robot_controller.ros.publishing import COUNTS_DIR_ENV
from robot_controller.ros.qos import ESTOP_QOS, LATEST_QOS, profile
from robot_controller.ros.stack_node import StackNode
from robot_controller.ros.ticks import clock_mode, tick_source_class

# The receipts come once a second, each message a second's rows: keep a few, never a backlog.
COMMAND_RECEIPTS_QOS = 5
LEVELS = {"ok": DiagnosticStatus.OK, "warn": DiagnosticStatus.WARN}


class ControllerLog:
    """The block's lines in the node's log: warnings rate-limited per key, or said every time, and errors."""

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


class ControllerNode(StackNode):
    def __init__(self) -> None:
        # Its parameter services are live_gains', on a thread of their own (started last, below).
        super().__init__("pid_controller", start_parameter_services=False)
        block = self.block
        self.command_pub = self.gated_publisher(Float64MultiArray, spec.COMMAND.topic)
        self.command_msg = Float64MultiArray()
        self.state_pub = self.gated_publisher(Float64MultiArray, spec.STATE.topic, consumer=False)
        self.state_msg = Float64MultiArray()
        self.state_msg.layout.dim = [
            MultiArrayDimension(label=label, size=size, stride=size) for label, size in block.state_blocks
        ]
        self.diagnostics_pub = self.gated_publisher(DiagnosticArray, spec.DIAGNOSTICS.topic, consumer=False)
        if not block.world_waits:
            # When each command reached the drive: the command path's delay, for the latency guard.
            self.create_subscription(
                Float64MultiArray,
                spec.COMMAND_RECEIPTS.topic,
                lambda msg: block.take(clock_s(self), {"command_receipts": decode(msg)}),
                COMMAND_RECEIPTS_QOS,
            )
        self.create_timer(self.params["diagnostics_period_s"], self.publish_diagnostics)
        self.reported_law = ""
        self.law_fault_left = False
        self.ticks: Any = None  # the clock, made once its inputs are subscribed
        readings_qos = profile(spec.READING.qos, world_waits=self.mode.world_waits)
        self.create_subscription(JointState, spec.READING.topic, self.reading_callback, readings_qos)
        self.watch_single_publisher(spec.READING.topic, spec.READING.writer)
        reference_qos = profile(spec.REFERENCE.qos, world_waits=self.mode.world_waits)
        self.create_subscription(Float64MultiArray, spec.REFERENCE.topic, self.reference_callback, reference_qos)
        self.watch_single_publisher(spec.REFERENCE.topic, spec.REFERENCE.writer)
        self.create_subscription(Bool, spec.ESTOP.topic, lambda msg: block.take(0.0, {"estop": msg.data}), ESTOP_QOS)
        self.create_subscription(
            Float64MultiArray, spec.BRAKES.topic, lambda msg: block.take(0.0, {"brakes": decode(msg)}), LATEST_QOS
        )
        self.ticks = tick_source_class(self.get_name(), self.mode)(self, block, self.tick)
        self.ticks.start()
        self.report_law()
        self.parameter_services = live_gains.ParameterServices(self)

    def setup(self, params: dict[str, Any]) -> None:
        # The same model again, for designing and checking a change in the designer's process (adaptation writes
        # its armature into the loop's own, and MuJoCo's data is not shared between threads).
        design_model = arm_model(params)
        self.designer = Designer(design_model, len(design_model.joint_names))
        world_waits = clock_mode(params).world_waits
        self.block: Controller = registry.block_class(self.get_name(), params)(
            params,
            ControllerLog(self),
            world_waits=world_waits,
            margin_of=self.designer.margin,
            run_wait=thread_kept_s,  # what the host took from the loop's thread is not the law's time
        )

    def more_specs(self, values: dict[str, Any]) -> tuple[cfg.ParamSpec, ...]:
        """A law of one's own: its declared parameters, law.NAME (a value given for one it does
        not declare is refused, as the launcher's check does)."""
        specs = law_params.law_specs(values["controller_type"])
        declared = {spec.name for spec in specs}
        overrides = getattr(self, "_parameter_overrides", {})  # --params-file and -p values
        for name in sorted(overrides):
            if law_parameters.is_law_key(name) and name not in declared:
                law_parameters.check_values({"controller_type": values["controller_type"], name: None}, self.get_name())
        return specs

    def check_params(self, params: dict[str, Any]) -> None:
        # On the parameter services' thread, waiting for the designer's process.
        self.block.check_params(params)

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        # On the parameter services' thread: the loop takes the change over at its next tick.
        self.block.set_params(params, changed)

    def reading_callback(self, msg: JointState) -> None:
        self.ticks.take("reading", decode(msg))

    def reference_callback(self, msg: Float64MultiArray) -> None:
        self.ticks.take("reference", decode(msg))

    def tick(self, t_s: float) -> dict[str, Any]:
        """Step the block at ``t_s`` and publish what it wrote: the command first."""
        outputs = self.block.step(t_s, {})
        command = outputs.get("command")
        if command is not None:
            self.command_msg.data = command.data.tolist()
            stamp_command(self.command_msg, t_s)
            self.command_pub.publish(self.command_msg)
        state = outputs.get("state")
        if state is not None:
            self.state_msg.data = state.data.tolist()
            self.state_pub.publish(self.state_msg)
        self.report_law()
        if self.block.law_fault_line is not None and not self.law_fault_left:
            self.leave_law_fault(self.block.law_fault_line)
        if self.block.exit_code is not None:
            request_exit(self.block.exit_code)
        return outputs

    def report_law(self) -> None:
        """The law and gains in force as the read-only parameter ``law_in_force``, when they change."""
        in_force = self.block.law_in_force
        if in_force != self.reported_law:
            self.reported_law = in_force
            self.report("law_in_force", in_force, "the control law and its gains in force, as designed")

    def leave_law_fault(self, line: str) -> None:
        """The failed law's line in the run's folder, for the launcher to name."""
        self.law_fault_left = True
        counts_dir = os.environ.get(COUNTS_DIR_ENV, "")
        if counts_dir:
            try:
                (Path(counts_dir) / LAW_FAULT_FILE).write_text(line + "\n")
            except OSError:
                pass  # the launcher then only knows the node's exit code

    def publish_diagnostics(self) -> None:
        said = self.block.diagnostics(clock_s(self))["diagnostics"]
        status = DiagnosticStatus(name=said.name, hardware_id="robot_controller")
        status.level, status.message = LEVELS[said.level], said.message
        status.values = [KeyValue(key=k, value=f"{v:.6g}") for k, v in said.values.items()]
        report = DiagnosticArray(status=[status])
        report.header.stamp = self.get_clock().now().to_msg()
        self.diagnostics_pub.publish(report)

    def finish(self) -> None:
        self.parameter_services.stop()
        self.designer.stop()
        self.ticks.finish()

    def destroy_node(self) -> None:
        self.parameter_services.stop()  # its thread first: it answers for this node
        self.designer.stop()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return run(ControllerNode, args)
