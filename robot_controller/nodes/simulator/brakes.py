"""The simulator's drive protections (docs/design.md §4), as real hardware has them.

Each joint has a holding brake, engaged before the first effort, on e-stop
(``/estop``, ``std_msgs/Bool``, latched; or the ``/simulator/estop``
``std_srvs/SetBool`` service), when the motor asks (``/sim/brake``), and
when efforts stop arriving for ``drive_timeout_s``; a braked joint gets no
torque. The brakes' state goes out on ``/sim/brakes`` (one value per joint,
1 = engaged) whenever it changes and twice a second.
"""

from __future__ import annotations

import time

import numpy as np
from std_msgs.msg import Bool, Float64MultiArray, MultiArrayDimension
from std_srvs.srv import SetBool

from robot_controller.ros.publishing import GatedPublisher
from robot_controller.ros.qos import ESTOP_QOS, LATCHED_QOS

BRAKES_REPORT_PERIOD_NS = 500_000_000
# The simulator's own pause (frozen, starved) up to this long does not count
# against the drive's timeout; after a longer one it resumes braked (by then
# the controller has given up: sensor_timeout_s, 1 s by default).
MAX_EXCUSED_GAP_NS = 1_000_000_000


class SimulatorBrakes:
    """The brakes of the :class:`~robot_controller.nodes.simulator.node.Simulator`: why each
    is on (any reason holds it), who may ask, and the drive timeout that engages them."""

    def init_brakes(self) -> None:
        self.brake_reasons: set[str] = {"start"}
        self.plant.set_brakes(np.ones(self.joint_count, dtype=bool), self.params["brake_torque_nm"])
        self.last_effort_mono_ns = 0
        self.brakes_pub = GatedPublisher(self, Float64MultiArray, "/sim/brakes", consumer=False)
        self.brakes_msg = Float64MultiArray()
        self.brakes_msg.layout.dim = [
            MultiArrayDimension(label="engaged", size=self.joint_count, stride=self.joint_count)
        ]
        self.next_brakes_report_ns = 0
        self.create_subscription(Bool, "/sim/brake", self.brake_request_callback, LATCHED_QOS)
        self.brake_request_heard = False
        self.create_subscription(Bool, "/estop", self.estop_callback, ESTOP_QOS)
        self.create_service(SetBool, "/simulator/estop", self.estop_service)

    def set_brake(self, reason: str, on: bool) -> None:
        """Add or remove one reason for the brakes (lock held); the brakes hold
        while any reason does, and a braked joint gets no torque."""
        before = bool(self.brake_reasons)
        if on:
            self.brake_reasons.add(reason)
        else:
            self.brake_reasons.discard(reason)
        engaged = bool(self.brake_reasons)
        if engaged != before:
            self.plant.set_brakes(np.full(self.joint_count, engaged), self.params["brake_torque_nm"])
            if engaged:
                self.effort = np.zeros(self.joint_count)
            self.report_brakes()

    def report_brakes(self) -> None:
        self.brakes_msg.data = [1.0 if self.brake_reasons else 0.0] * self.joint_count
        self.brakes_pub.publish(self.brakes_msg)

    def report_brakes_periodically(self, now_ns: int) -> None:
        """Repeat the brakes' state twice a second (lock held), so a late listener learns it."""
        if now_ns >= self.next_brakes_report_ns:
            self.next_brakes_report_ns = now_ns + BRAKES_REPORT_PERIOD_NS
            self.report_brakes()

    def brake_request_callback(self, msg: Bool) -> None:
        with self.lock:
            self.brake_request_heard = True
            if bool(msg.data) != ("requested" in self.brake_reasons):
                self.get_logger().warning(
                    "brake requested by the motor: torque off, brakes on"
                    if msg.data
                    else "motor released its brake request"
                )
            self.set_brake("requested", bool(msg.data))

    def estop_callback(self, msg: Bool) -> None:
        self.set_estop(bool(msg.data))

    def estop_service(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        self.set_estop(bool(request.data))
        response.success = True
        response.message = "e-stop engaged: torque off, brakes on" if request.data else "e-stop released"
        return response

    def set_estop(self, on: bool) -> None:
        with self.lock:
            if on == ("estop" in self.brake_reasons):
                return
            if self.anchor_mono_ns is not None and not self.lockstep:
                self.advance(time.monotonic_ns())
            self.set_brake("estop", on)
        self.get_logger().warning(
            "E-STOP: torque off, brakes on (latched until released)"
            if on
            else "e-stop released: brakes release when efforts arrive"
        )
        if not on:
            with self.lock:
                # Released, the brakes wait for the drive's next effort.
                self.set_brake("drive_timeout", True)

    # --- drive timeout (wall clock) ---------------------------------------------

    def excuse_own_gap(self, gap_ns: int, period_ns: int) -> None:
        """Account for a pause of this process between two wake-ups ``gap_ns`` apart (lock held)."""
        if gap_ns > 2 * period_ns and self.anchor_mono_ns is not None:
            if gap_ns <= MAX_EXCUSED_GAP_NS:
                # This process was not running (frozen, starved) for a moment: that
                # time does not count against the drive, whose efforts are waiting to be read.
                self.last_effort_mono_ns += gap_ns - period_ns
            elif "drive_timeout" not in self.brake_reasons:
                # Longer, and the efforts waiting are as old: resume braked (the arm
                # holds from here), until a fresh one arrives.
                self.set_brake("drive_timeout", True)
                self.warn_throttled(
                    "own_gap",
                    f"this simulator did not run for {gap_ns * 1e-9:.2f} s: " "resuming with the brakes on",
                )

    def check_drive_timeout(self, now_ns: int) -> None:
        """Brake once no effort has arrived for ``drive_timeout_s`` (lock held, physics running):
        the physics up to now runs on the last torque, then the torque is off (category 0)."""
        if now_ns - self.last_effort_mono_ns > self.drive_timeout_ns and "drive_timeout" not in self.brake_reasons:
            self.advance(now_ns)
            self.set_brake("drive_timeout", True)
            self.warn_throttled(
                "drive_timeout",
                f"no effort for over {self.params['drive_timeout_s']:g} " "s: torque off, brakes on (category 0)",
            )
