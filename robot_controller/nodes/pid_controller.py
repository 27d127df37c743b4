"""pid_controller (the name the tutorial and users' files know): the law ``controller_type`` selects at
``control_rate_hz``, from the ports ``reading`` and ``reference`` to ``command``, ``state`` and ``diagnostics``; the
controller block (``blocks.controller``) hosted by the adapter (``ros.adapter``), stepped by its clock
(``ros.controller_ticks``); beside it, its parameter services on a thread of their own and a change's law designed in a
process of its own (``live_gains``), the law in force reported as a parameter and its diagnostics on a timer. Every
decision about torque is the block's core's."""

from __future__ import annotations

from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from robot_controller import parameters as cfg
from robot_controller.blocks import spec
from robot_controller.blocks.block import Block, block_class
from robot_controller.core.laws import law_parameters
from robot_controller.nodes import live_gains
from robot_controller.nodes.live_gains import Designer
from robot_controller.parameters import law_params
from robot_controller.parameters.builders import arm_model
from robot_controller.ros.adapter import BlockNode, Extras
from robot_controller.ros.loop_processes import thread_kept_s
from robot_controller.ros.messages import clock_s
from robot_controller.ros.process import LAW_FAULT_FILE, request_exit, run
from robot_controller.ros.publishing import leave

# The receipts come once a second, each message a second's rows: keep a few, never a backlog.
COMMAND_RECEIPTS_QOS = 5
LEVELS = {"ok": DiagnosticStatus.OK, "warn": DiagnosticStatus.WARN}


class ControllerExtras(Extras):
    # Its parameter services are live_gains', on a thread of their own (started last).
    node_options = {"start_parameter_services": False}

    def __init__(self, node: BlockNode) -> None:
        super().__init__(node)
        self.reported_law = ""
        self.law_fault_left = False
        self.designer: Designer | None = None
        self.parameter_services: live_gains.ParameterServices | None = None

    def more_specs(self, values: dict[str, Any]) -> tuple[cfg.ParamSpec, ...]:
        """A law of one's own: its declared parameters, law.NAME (a value given for one it does
        not declare is refused, as the launcher's check does)."""
        specs = law_params.law_specs(values["controller_type"])
        declared = {spec.name for spec in specs}
        overrides = getattr(self.node, "_parameter_overrides", {})  # --params-file and -p values
        for name in sorted(overrides):
            if law_parameters.is_law_key(name) and name not in declared:
                law_parameters.check_values(
                    {"controller_type": values["controller_type"], name: None}, self.node.get_name()
                )
        return specs

    def make_block(self, params: dict[str, Any], world_waits: bool) -> Block:
        # The same model again, for designing and checking a change in the designer's process (adaptation writes
        # its armature into the loop's own, and MuJoCo's data is not shared between threads).
        design_model = arm_model(params)
        self.designer = Designer(design_model, len(design_model.joint_names))
        return block_class(self.node.get_name(), params)(
            params,
            self.node,
            world_waits=world_waits,
            margin_of=self.designer.margin,
            run_wait=thread_kept_s,  # what the host took from the loop's thread is not the law's time
        )

    def reader_qos(self, port: spec.Port) -> Any:
        if port.name == "command_receipts":
            # When each command reached the drive: the command path's delay, for the latency guard (wall clock).
            return None if self.node.mode.world_waits else COMMAND_RECEIPTS_QOS
        return super().reader_qos(port)

    def watched(self, port: spec.Port) -> bool:
        return port.name in ("reading", "reference")

    def layout(self, port: spec.Port) -> list[tuple[str, int]] | None:
        return list(self.node.block.state_blocks) if port.name == "state" else None  # the command: by its tick

    def make_ticks(self, source: type) -> Any:
        return source(self.node, self.node.block, self.tick)

    def start(self) -> None:
        self.node.create_timer(self.node.params["diagnostics_period_s"], self.publish_diagnostics)
        self.report_law()
        self.parameter_services = live_gains.ParameterServices(self.node)

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        # On the parameter services' thread: the loop takes the change over at its next tick.
        self.node.block.set_params(params, changed)

    def tick(self, t_s: float) -> dict[str, Any]:
        """Step the block at ``t_s`` and publish what it wrote: the command first."""
        block = self.node.block
        outputs = block.step(t_s, {})
        self.node.publish(outputs)
        self.report_law()
        if block.reports.law_fault_line is not None and not self.law_fault_left:
            self.leave_law_fault(block.reports.law_fault_line)
        if block.exit_code is not None:
            request_exit(block.exit_code)
        return outputs

    def report_law(self) -> None:
        """The law and gains in force as the read-only parameter ``law_in_force``, when they change."""
        in_force = self.node.block.reports.law_in_force
        if in_force != self.reported_law:
            self.reported_law = in_force
            self.node.report("law_in_force", in_force, "the control law and its gains in force, as designed")

    def leave_law_fault(self, line: str) -> None:
        """The failed law's line in the run's folder, for the launcher to name."""
        self.law_fault_left = True
        leave(LAW_FAULT_FILE, line + "\n")  # lost, the launcher knows the node's exit code only

    def publish_diagnostics(self) -> None:
        said = self.node.block.timing.diagnostics(clock_s(self.node))
        status = DiagnosticStatus(name=said.name, hardware_id="robot_controller")
        status.level, status.message = LEVELS[said.level], said.message
        status.values = [KeyValue(key=k, value=f"{v:.6g}") for k, v in said.values.items()]
        report = DiagnosticArray(status=[status])
        report.header.stamp = self.node.get_clock().now().to_msg()
        self.node.publishers_by_port["diagnostics"][0].publish(report)

    def finish(self) -> None:
        self.destroy()

    def destroy(self) -> None:
        if self.parameter_services is not None:
            self.parameter_services.stop()  # its thread first: it answers for this node
        if self.designer is not None:
            self.designer.stop()


def ControllerNode() -> BlockNode:  # noqa: N802 (made as a node class is, by ``ros.process.run``)
    return BlockNode("pid_controller", ControllerExtras)


def main(args: list[str] | None = None) -> int:
    return run(ControllerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
