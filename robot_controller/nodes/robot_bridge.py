"""The ROS side of a robot's drive (``robot_node``): a node, ``robot_drive``, that hands the planner's samples and the
e-stop to the drive and publishes what the drive recorded, every 10 ms. It lives as long as the drive: the run's end
(SIGINT) asks the drive to stop and waits for it; the drive's fault or death ends it with the failure."""

from __future__ import annotations

import json
import os
import threading
import time
from typing import Any

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64MultiArray, MultiArrayDimension

from robot_controller.blocks import spec
from robot_controller.blocks.values import brakes_label, check_trajectory
from robot_controller.hardware.robot_link import END, ESTOP, GO, TELEMETRY_EVERY, RobotLink, TickRow
from robot_controller.hardware.robot_timing import RobotTiming
from robot_controller.nodes.robot_gains import gains_node
from robot_controller.ros import process
from robot_controller.ros.process import ROBOT_FAULT_FILE, ROBOT_TIMING_FILE
from robot_controller.ros.publishing import GatedPublisher, leave, write_publish_counts
from robot_controller.ros.qos import ESTOP_QOS, LATEST_QOS

NODE_NAME = "robot_drive"
PUMP_PERIOD_S = 0.01
#: s the drive may take to stop after the run's end, past which it is killed (the robot's own watchdog stops it)
END_TIMEOUT_S = 7.0
#: why the brakes hold, by the drive's phase
HELD_BY = {"estopped": {"estop"}, "fault": {"robot_fault"}, "ended": {"end"}}


class RobotBridge(Node):
    """The drive's face to the graph (see the module): its inputs to the link, its record to the topics."""

    def __init__(self, drive_pid: int, link: RobotLink, joint_names: list[str], state_blocks: list) -> None:
        super().__init__(NODE_NAME)
        self.drive_pid, self.link, self.joint_names = drive_pid, link, joint_names
        self.exit_code: int | None = None  #: the drive's, once it has ended
        self.timing = RobotTiming()
        self.ticks = 0
        self.phase = "starting"
        self._lost_said = 0.0

        def gate(msg_type: Any, port: spec.Port) -> GatedPublisher:  # telemetry: waits for the recorder alone
            return GatedPublisher(self, msg_type, port.topic, world_waits=False, consumer=False)

        self.gates = {
            "state": gate(Float64MultiArray, spec.STATE),
            "true_state": gate(JointState, spec.TRUE_STATE),
            "reading": gate(JointState, spec.READING),
            "brakes": gate(Float64MultiArray, spec.BRAKES),
            "diagnostics": gate(DiagnosticArray, spec.DIAGNOSTICS),
        }
        self.state_msg = Float64MultiArray()
        self.state_msg.layout.dim = [
            MultiArrayDimension(label=label, size=size, stride=size) for label, size in state_blocks
        ]
        self.create_subscription(Float64MultiArray, spec.REFERENCE.topic, self._on_reference, LATEST_QOS)
        self.create_subscription(Bool, spec.ESTOP.topic, self._on_estop, ESTOP_QOS)
        self.create_timer(PUMP_PERIOD_S, self.pump)
        self.create_timer(1.0, self._diagnostics)
        self.get_logger().info(f"the robot's drive is process {drive_pid}; waiting for the recorder")

    # --- to the drive ------------------------------------------------------------------

    def _on_reference(self, msg: Float64MultiArray) -> None:
        checked = check_trajectory(msg.data, len(self.joint_names))
        if isinstance(checked, str):
            self.get_logger().warning(f"{spec.REFERENCE.topic} dropped: {checked}", throttle_duration_sec=2.0)
            return
        *values, sample_s = checked  # the tutorial's samples have no time: taken as of their arrival
        now_s = self.get_clock().now().nanoseconds * 1e-9
        self.link.offer_reference(sample_s if sample_s is not None else now_s, np.concatenate(values))

    def _on_estop(self, msg: Bool) -> None:
        if msg.data and not self.link.requested(ESTOP):
            self.get_logger().warning("e-stop: stopping the robot (a controlled stop, then libfranka's stop)")
            self.link.request(ESTOP)

    # --- from the drive ----------------------------------------------------------------

    def pump(self) -> None:
        """Publish what the drive recorded since the last call; follow its phase; notice its end."""
        if not self.link.requested(GO) and all(
            g.open for g in self.gates.values() if g is not self.gates["diagnostics"]
        ):
            self.link.request(GO)
        rows, lost = self.link.rows()
        for row in rows:
            self._publish(row)
        if lost and time.monotonic() - self._lost_said > 2.0:
            self._lost_said = time.monotonic()
            self.get_logger().warning(f"{lost} ticks of the drive's record were overwritten before published")
        phase = self.link.phase()
        if phase != self.phase:
            self.phase = phase
            self._brakes(HELD_BY.get(phase))
        if self.exit_code is None:
            pid, status = os.waitpid(self.drive_pid, os.WNOHANG)
            if pid == self.drive_pid:
                self.exit_code = os.waitstatus_to_exitcode(status)
                self._drive_ended()

    def _publish(self, row: TickRow) -> None:
        self.timing.take(row.compute_s, row.success_rate, row.missed)
        if self.ticks % TELEMETRY_EVERY == 0:
            self.state_msg.data = row.state.tolist()
            self.gates["state"].publish(self.state_msg)
            stamp = divmod(round(row.time_s * 1e9), 1_000_000_000)
            true_state = JointState(name=self.joint_names, position=row.position.tolist())
            true_state.velocity, true_state.effort = row.velocity.tolist(), row.torque_nm.tolist()
            true_state.header.stamp.sec, true_state.header.stamp.nanosec = stamp
            self.gates["true_state"].publish(true_state)
            reading = JointState(name=self.joint_names, position=true_state.position, velocity=true_state.velocity)
            reading.header.stamp = true_state.header.stamp
            self.gates["reading"].publish(reading)
        self.ticks += 1

    def _brakes(self, reasons: set[str] | None) -> None:
        n = len(self.joint_names)
        msg = Float64MultiArray(data=[1.0 if reasons else 0.0] * n)
        msg.layout.dim = [MultiArrayDimension(label=brakes_label(reasons or set()), size=n, stride=n)]
        self.gates["brakes"].publish(msg)

    def _drive_ended(self) -> None:
        code = self.exit_code
        if code is not None and code < 0:
            line = (
                f"the robot's drive (process {self.drive_pid}) died (signal {-code}) while it held the robot: the "
                "robot stopped itself when its commands stopped (its communication watchdog)"
            )
            leave(ROBOT_FAULT_FILE, line)
            self.get_logger().error(line)
            self._brakes({"robot_fault"})

    def _diagnostics(self) -> None:
        figures = self.timing.figures()
        status = DiagnosticStatus(name=f"{NODE_NAME}: robot timing", hardware_id="franka")
        status.values = [KeyValue(key=k, value=f"{v:.6g}") for k, v in figures.items()]
        self.gates["diagnostics"].publish(DiagnosticArray(status=[status]))

    def finish(self) -> None:
        self.pump()
        leave(ROBOT_TIMING_FILE, json.dumps(self.timing.figures()))


def serve(
    ros_args: list[str], drive_pid: int, link: RobotLink, joint_names: list[str], state_blocks: list, send_gains
) -> int:
    """Spin until the drive has ended (after the run's end asked it to, or on its own); its exit code. Beside the
    bridge, the controller's parameters (``robot_gains``): a checked change goes to the drive through ``send_gains``."""
    process.init_with_own_signals(ros_args)
    node = RobotBridge(drive_pid, link, joint_names, state_blocks)
    gains = gains_node(send_gains)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    # The gains on a thread of their own: a change waits for its design (in a worker process), and the planner's
    # samples must go on reaching the drive meanwhile.
    gains_executor = SingleThreadedExecutor()
    gains_executor.add_node(gains)
    threading.Thread(target=process.spin, args=(gains_executor,), name="gains", daemon=True).start()
    ending_since: float | None = None
    try:
        while node.exit_code is None:
            executor.spin_once(timeout_sec=process.SPIN_WAKE_S)
            if process.stop_requested() and ending_since is None:
                ending_since = time.monotonic()
                link.request(END)
            if ending_since is not None and time.monotonic() - ending_since > END_TIMEOUT_S:
                node.get_logger().error(
                    "the drive did not stop within its time: killed (the robot's watchdog stops it)"
                )
                os.kill(drive_pid, 9)
                ending_since = float("inf")
        node.finish()
        for gated in node.gates.values():
            gated.publisher.wait_for_all_acked(rclpy.duration.Duration(seconds=1.0))
        write_publish_counts(NODE_NAME, list(node.gates.values()))
    finally:
        executor.shutdown(timeout_sec=1.0)
        gains_executor.shutdown(timeout_sec=1.0)
        gains.destroy_node()
        node.destroy_node()
        rclpy.try_shutdown()
    code = node.exit_code or 0
    return code if code >= 0 else 1
