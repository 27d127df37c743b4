"""The simulator's external disturbances: port ``disturbance`` (``[torque_nm…, duration_s]``), a torque on each joint
beside the actuator's (not cut by the brakes; capped at ``MAX_DISTURBANCE_NM``) until replaced;
port ``disturbance_applied``, ``[torque_nm…, time_s]``, goes with every true state while it acts, and once more, zero,
after."""

from __future__ import annotations

import numpy as np
from std_msgs.msg import Float64MultiArray, MultiArrayDimension

from robot_controller import parameters as cfg
from robot_controller.blocks import spec
from robot_controller.core.model import MAX_DISTURBANCE_NM, check_disturbance
from robot_controller.ros.qos import LATEST_QOS
from robot_controller.ros.stack_node import StackNode


class Disturbance:
    """The external torque: taken like an effort, applied in the physics beside it."""

    def __init__(self, node: StackNode) -> None:
        self.node = node
        self.plant = node.plant
        node.create_subscription(Float64MultiArray, spec.DISTURBANCE.topic, self.callback, LATEST_QOS)
        self.pub = node.gated_publisher(Float64MultiArray, spec.DISTURBANCE_APPLIED.topic, consumer=False)
        self.msg = Float64MultiArray()
        self.msg.layout.dim = [
            MultiArrayDimension(label="torque_nm", size=node.joint_count, stride=node.joint_count),
            MultiArrayDimension(label="time_s", size=1, stride=1),
        ]
        self.on = False  #: one is being applied (for the line when it ends)
        self.started_s = 0.0  #: physics time it started and ends at
        self.ends_s = 0.0
        self.reported = False  #: the last disturbance applied was not zero
        self.scheduled_done = False  #: the parameters' one has started (or there is none)

    def callback(self, msg: Float64MultiArray) -> None:
        node = self.node
        checked = check_disturbance(msg.data, node.joint_count)
        if isinstance(checked, str):
            return node.drop(spec.DISTURBANCE.topic, checked)
        torque, duration_s = checked
        if np.any(np.abs(torque) > MAX_DISTURBANCE_NM):
            node.warn_throttled(
                "disturbance_limit",
                f"{spec.DISTURBANCE.topic} {torque.tolist()} N·m beyond {MAX_DISTURBANCE_NM:g} N·m per joint: capped",
            )
            torque = np.clip(torque, -MAX_DISTURBANCE_NM, MAX_DISTURBANCE_NM)
        with node.lock:
            node.catch_up()  # the physics up to now ran without it
            self.start(torque, duration_s)

    def start_scheduled(self) -> None:
        """The parameters' disturbance, once physics time reaches ``disturbance_start_s`` (lock held)."""
        params = self.node.params
        if self.scheduled_done or self.plant.time_s + 1e-9 < params["disturbance_start_s"]:
            return
        self.scheduled_done = True
        torque = cfg.per_joint("disturbance_torque_nm", params["disturbance_torque_nm"], self.node.joint_count)
        torque = np.clip(torque, -MAX_DISTURBANCE_NM, MAX_DISTURBANCE_NM)
        if np.any(torque != 0.0):
            self.start(torque, params["disturbance_duration_s"])

    def start(self, torque: np.ndarray, duration_s: float) -> None:
        """Apply ``torque`` (N·m per joint) for ``duration_s`` of physics time from now (lock held)."""
        log = self.node.get_logger()
        replaced = self.on
        self.plant.set_disturbance(torque, duration_s)
        now_s = self.plant.time_s
        if not self.plant.disturbance_active:
            if replaced:
                self.on = False
                after = f"after {now_s - self.started_s:.3f} s"
                log.info(f"disturbance ended at physics t = {now_s:.3f} s ({after}): replaced by a zero one")
            else:
                log.info("disturbance of zero torque or duration received: nothing to apply")
            return
        self.on = True
        self.started_s = now_s
        self.ends_s = now_s + self.plant.disturbance_remaining_s
        joints = ", ".join(f"{name} {value:g}" for name, value in zip(self.plant.joint_names, torque, strict=True))
        notes = []
        if replaced:
            notes.append("replacing the one in force")
        if self.node.brakes.reasons:
            notes.append("brakes on: they hold against it")
        if self.node.pacing is not None and not self.node.pacing.running:
            notes.append("acting once the physics runs (first command)")
        log.info(
            f"disturbance started: {joints} N·m for {duration_s:g} s from physics t = {now_s:.3f} s"
            + (f" ({'; '.join(notes)})" if notes else "")
        )

    def note_end(self) -> None:
        """After the physics stepped (lock held): say when a disturbance has run its course."""
        if self.on and not self.plant.disturbance_active:
            self.on = False
            applied = f"applied for {self.ends_s - self.started_s:.3f} s"
            self.node.get_logger().info(f"disturbance ended at physics t = {self.ends_s:.3f} s ({applied})")

    def publish_applied(self, stamp_ns: int) -> None:
        """The disturbance that acted in the last physics step: with every state while there is one, then once zero."""
        applied = self.plant.disturbance_torque
        nonzero = bool(applied.any())
        if nonzero or self.reported:
            self.msg.data = applied.tolist() + [stamp_ns * 1e-9]
            self.pub.publish(self.msg)
            self.reported = nonzero
