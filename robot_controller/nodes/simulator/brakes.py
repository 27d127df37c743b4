"""The simulator's holding brakes (docs/design.md §4): on before the first effort, on e-stop (port ``estop``
or the ``estop_button`` service), on the motor's request (port ``brake_request``) and after ``drive_timeout_s`` without
efforts. Their state goes out on port ``brakes`` (1 = engaged, and why in its label) on every change, and twice a second
on the wall clock."""

from __future__ import annotations

import numpy as np
from std_msgs.msg import Bool, Float64MultiArray, MultiArrayDimension
from std_srvs.srv import SetBool

from robot_controller.blocks import spec
from robot_controller.ros.messages import brakes_label
from robot_controller.ros.process import stop_requested
from robot_controller.ros.qos import ESTOP_QOS, LATCHED_QOS
from robot_controller.ros.stack_node import StackNode

REPORT_PERIOD_NS = 500_000_000
# The simulator's own pause up to this long does not count against the drive's timeout; a longer one brakes.
MAX_EXCUSED_GAP_NS = 1_000_000_000


class Brakes:
    """Why each brake is on (any reason holds it), who may ask, and the drive timeout."""

    def __init__(self, node: StackNode) -> None:
        self.node = node
        self.reasons: set[str] = {"start"}
        node.plant.set_brakes(np.ones(node.joint_count, dtype=bool), node.params["brake_torque_nm"])
        self.last_effort_mono_ns = 0
        self.timeout_ns = round(1e9 * node.params["drive_timeout_s"])
        self.pub = node.gated_publisher(Float64MultiArray, spec.BRAKES.topic, consumer=False)
        self.msg = Float64MultiArray()
        self.msg.layout.dim = [MultiArrayDimension(label="engaged", size=node.joint_count, stride=node.joint_count)]
        self.next_report_ns = 0
        self.request_heard = False
        node.create_subscription(Bool, spec.BRAKE_REQUEST.topic, self.request_callback, LATCHED_QOS)
        node.create_subscription(Bool, spec.ESTOP.topic, lambda msg: self.set_estop(bool(msg.data)), ESTOP_QOS)
        node.create_service(SetBool, spec.ESTOP_SERVICE.service, self.estop_service)

    def set(self, reason: str, on: bool) -> None:
        """Add or remove one reason for the brakes (lock held); they hold while any reason does."""
        before = bool(self.reasons)
        if on:
            self.reasons.add(reason)
        else:
            self.reasons.discard(reason)
        engaged = bool(self.reasons)
        if engaged != before:
            node = self.node
            node.plant.set_brakes(np.full(node.joint_count, engaged), node.params["brake_torque_nm"])
            if engaged:
                node.effort = np.zeros(node.joint_count)
            self.report()

    def report(self) -> None:
        self.msg.data = [1.0 if self.reasons else 0.0] * self.node.joint_count
        self.msg.layout.dim[0].label = brakes_label(self.reasons)  # why: the start's are a lockstep controller's race
        self.pub.publish(self.msg)

    def report_periodically(self, now_ns: int) -> None:
        """Repeat the state twice a second (lock held), so a late listener learns it."""
        if now_ns >= self.next_report_ns:
            self.next_report_ns = now_ns + REPORT_PERIOD_NS
            self.report()

    def request_callback(self, msg: Bool) -> None:
        with self.node.lock:
            self.request_heard = True
            if bool(msg.data) != ("requested" in self.reasons):
                self.node.get_logger().warning(
                    "brake requested by the motor: torque off, brakes on"
                    if msg.data
                    else "motor released its brake request"
                )
            self.set("requested", bool(msg.data))

    def estop_service(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        self.set_estop(bool(request.data))
        response.success = True
        response.message = "e-stop engaged: torque off, brakes on" if request.data else "e-stop released"
        return response

    def set_estop(self, on: bool) -> None:
        node = self.node
        with node.lock:
            if on == ("estop" in self.reasons):
                return
            node.catch_up()
            self.set("estop", on)
        node.get_logger().warning(
            "E-STOP: torque off, brakes on (latched until released)"
            if on
            else "e-stop released: brakes release when efforts arrive"
        )
        if not on:
            with node.lock:
                self.set("drive_timeout", True)  # released, the brakes wait for the drive's next effort

    def excuse_own_gap(self, gap_ns: int, period_ns: int) -> None:
        """Account for a pause of this process between two wake-ups ``gap_ns`` apart (lock held, physics running)."""
        if gap_ns <= 2 * period_ns:
            return
        if gap_ns <= MAX_EXCUSED_GAP_NS:
            # Time this process did not run does not count against the drive, whose efforts are waiting.
            self.last_effort_mono_ns += gap_ns - period_ns
        elif "drive_timeout" not in self.reasons:
            # The efforts waiting are as old as the pause: resume braked until a fresh one arrives.
            self.set("drive_timeout", True)
            self.node.warn_throttled(
                "own_gap", f"this simulator did not run for {gap_ns * 1e-9:.2f} s: resuming with the brakes on"
            )

    def check_drive_timeout(self, now_ns: int) -> None:
        """Brake when no effort came for ``drive_timeout_s`` (lock held); physics to now on the old torque, then off."""
        if now_ns - self.last_effort_mono_ns > self.timeout_ns and "drive_timeout" not in self.reasons:
            self.node.pacing.advance(now_ns)
            self.set("drive_timeout", True)
            if stop_requested():  # the run's end (SIGINT to every node): the drive stopped first
                return
            self.node.warn_throttled(
                "drive_timeout",
                f"no effort for over {self.node.params['drive_timeout_s']:g} s: torque off, brakes on (category 0)",
            )
