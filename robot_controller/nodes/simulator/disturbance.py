"""The simulator's external disturbances.

``/sim/disturbance`` (``std_msgs/Float64MultiArray`` ``[torque_nm…,
duration_s]``) is an external torque on each joint, in the physics beside the
actuator's (not limited by the drive, not cut by the brakes, which hold
against it as against gravity; capped at ``MAX_DISTURBANCE_NM``), from its
arrival (wall clock) or the next tick (lockstep) for ``duration_s`` of physics
time; a new one replaces it. The torque acting goes out on
``/sim/disturbance_applied`` ``[torque_nm…, time_s]`` (``time_s`` = the true
state's stamp) with every true state while it is on, and once more, zero,
when it ends.
"""

from __future__ import annotations

import time

import numpy as np
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from robot_controller import parameters as cfg
from robot_controller.core.model import MAX_DISTURBANCE_NM, check_disturbance
from robot_controller.ros.publishing import GatedPublisher
from robot_controller.ros.qos import LATEST_QOS


class SimulatorDisturbance:
    """The disturbances of the :class:`~robot_controller.nodes.simulator.node.Simulator`:
    taken like an effort, applied in the physics beside it."""

    def init_disturbance(self) -> None:
        self.create_subscription(Float64MultiArray, "/sim/disturbance", self.disturbance_callback, LATEST_QOS)
        self.disturbance_pub = GatedPublisher(self, Float64MultiArray, "/sim/disturbance_applied", consumer=False)
        self.disturbance_msg = Float64MultiArray()
        self.disturbance_msg.layout.dim = [
            MultiArrayDimension(label="torque_nm", size=self.joint_count, stride=self.joint_count),
            MultiArrayDimension(label="time_s", size=1, stride=1),
        ]
        self.disturbance_on = False  #: one is being applied (for the INFO line when it ends)
        self.disturbance_started_s = 0.0  #: physics time it started and ends at
        self.disturbance_ends_s = 0.0
        self.disturbance_reported = False  #: the last /sim/disturbance_applied was not zero
        self.scheduled_disturbance_done = False  #: the parameters' one has started (or there is none)

    def disturbance_callback(self, msg: Float64MultiArray) -> None:
        checked = check_disturbance(msg.data, self.joint_count)
        if isinstance(checked, str):
            self.warn_throttled("disturbance", f"/sim/disturbance dropped: {checked}")
            return
        torque, duration_s = checked
        if np.any(np.abs(torque) > MAX_DISTURBANCE_NM):
            self.warn_throttled(
                "disturbance_limit",
                f"/sim/disturbance {torque.tolist()} N·m beyond " f"{MAX_DISTURBANCE_NM:g} N·m per joint: capped",
            )
            torque = np.clip(torque, -MAX_DISTURBANCE_NM, MAX_DISTURBANCE_NM)
        with self.lock:
            if not self.lockstep and self.anchor_mono_ns is not None:
                # Physics up to now ran without it; it acts from here.
                self.advance(time.monotonic_ns())
            self.start_disturbance(torque, duration_s)

    def start_scheduled_disturbance(self) -> None:
        """The parameters' disturbance, once physics time reaches ``disturbance_start_s`` (lock held):
        the same input as ``/sim/disturbance``, at a time a lockstep run reproduces exactly."""
        if self.scheduled_disturbance_done or self.plant.time_s + 1e-9 < self.params["disturbance_start_s"]:
            return
        self.scheduled_disturbance_done = True
        torque = np.clip(
            cfg.per_joint("disturbance_torque_nm", self.params["disturbance_torque_nm"], self.joint_count),
            -MAX_DISTURBANCE_NM,
            MAX_DISTURBANCE_NM,
        )
        if np.any(torque != 0.0):
            self.start_disturbance(torque, self.params["disturbance_duration_s"])

    def start_disturbance(self, torque: np.ndarray, duration_s: float) -> None:
        """Apply ``torque`` (N·m per joint) for ``duration_s`` of physics time from now (lock held)."""
        replaced = self.disturbance_on
        self.plant.set_disturbance(torque, duration_s)
        now_s = self.plant.time_s
        if not self.plant.disturbance_active:
            if replaced:
                self.disturbance_on = False
                self.get_logger().info(
                    f"disturbance ended at physics t = {now_s:.3f} s (after "
                    f"{now_s - self.disturbance_started_s:.3f} s): replaced by a zero one"
                )
            else:
                self.get_logger().info("disturbance of zero torque or duration received: nothing to apply")
            return
        self.disturbance_on = True
        self.disturbance_started_s = now_s
        self.disturbance_ends_s = now_s + self.plant.disturbance_remaining_s
        joints = ", ".join(f"{name} {value:g}" for name, value in zip(self.plant.joint_names, torque, strict=True))
        notes = []
        if replaced:
            notes.append("replacing the one in force")
        if self.brake_reasons:
            notes.append("brakes on: they hold against it")
        if not self.lockstep and self.anchor_mono_ns is None:
            notes.append("acting once the physics runs (first command)")
        self.get_logger().info(
            f"disturbance started: {joints} N·m for {duration_s:g} s from physics "
            f"t = {now_s:.3f} s" + (f" ({'; '.join(notes)})" if notes else "")
        )

    def note_disturbance_end(self) -> None:
        """After the physics stepped (lock held): say when a disturbance has run its course."""
        if self.disturbance_on and not self.plant.disturbance_active:
            self.disturbance_on = False
            self.get_logger().info(
                f"disturbance ended at physics t = {self.disturbance_ends_s:.3f} s (applied "
                f"for {self.disturbance_ends_s - self.disturbance_started_s:.3f} s)"
            )

    def publish_disturbance_applied(self, stamp_ns: int) -> None:
        """The disturbance that acted in the last physics step: with every state while
        there is one, then once zero."""
        applied = self.plant.disturbance_torque
        nonzero = bool(applied.any())
        if nonzero or self.disturbance_reported:
            self.disturbance_msg.data = applied.tolist() + [stamp_ns * 1e-9]
            self.disturbance_pub.publish(self.disturbance_msg)
            self.disturbance_reported = nonzero
