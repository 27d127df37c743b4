"""The simulator node's shell: its parameters, the effort taken in and the true state sent out.

The concerns it joins live beside it: the wall clock in ``pacing``, the
brakes and drive timeout in ``brakes``, sim time in ``lockstep`` and external
torques in ``disturbance``; they share the node's plant, effort and lock.
"""

from __future__ import annotations

import os
import time

import numpy as np
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.model import MujocoPlant, Payload, steps_per_period
from robot_controller.core.validation import check_effort
from robot_controller.nodes.simulator.brakes import SimulatorBrakes
from robot_controller.nodes.simulator.disturbance import SimulatorDisturbance
from robot_controller.nodes.simulator.lockstep import SimulatorLockstep
from robot_controller.nodes.simulator.pacing import SimulatorPacing
from robot_controller.nodes.world_state import WORLD_STATE_ENV, WorldState
from robot_controller.ros.process import run
from robot_controller.ros.publishing import GatedPublisher
from robot_controller.ros.qos import loop_qos
from robot_controller.ros.stack_node import StackNode


class Simulator(SimulatorPacing, SimulatorLockstep, SimulatorBrakes, SimulatorDisturbance, StackNode):
    def __init__(self) -> None:
        super().__init__("simulator")
        p = self.params
        self.plant = MujocoPlant(
            resources.resolve_urdf(p["urdf_path"]),
            1.0 / p["physics_rate_hz"],
            Payload.from_values("payload", p["payload"]),
        )
        self.joint_count = len(self.plant.joint_names)
        self.plant.reset(cfg.per_joint("initial_position", p["initial_position"], self.joint_count))
        self.world = WorldState.open(os.environ.get(WORLD_STATE_ENV, ""), self.joint_count)
        if self.world is not None and self.world.resumed is not None:
            self.plant.reset(self.world.resumed)
            self.get_logger().warning(
                f"respawned: the arm is where it was, at {self.world.resumed.tolist()} rad, "
                "brakes on until the first command"
            )
        self.effort = np.zeros(self.joint_count)
        self.steps_done = 0
        self.physics_dt_ns = round(self.plant.physics_dt * 1e9)
        self.init_pacing()
        self.init_lockstep()

        self.state_pub = GatedPublisher(self, JointState, "/sim/joint_states")
        # Only the newest effort matters to a drive (lockstep sends one at a time anyway).
        self.effort_sub = self.create_subscription(
            Float64MultiArray, "/sim/effort", self.effort_callback, loop_qos(self.lockstep)
        )
        self.watch_single_publisher("/sim/effort", "motor_node")
        self.init_brakes()
        self.state_msg = JointState()
        self.state_msg.name = list(self.plant.joint_names)
        self.init_disturbance()
        if self.lockstep:
            self.start_lockstep_clock()
        else:
            self.start_pacing()
        self.get_logger().info(
            f"MuJoCo arm {self.plant.joint_names} at {p['physics_rate_hz']:g} Hz physics, "
            + (
                f"lockstep at {p['control_rate_hz']:g} Hz on /clock"
                if self.lockstep
                else f"true state at {p['publish_rate_hz']:g} Hz, paced on absolute deadlines"
                + (", brakes on until the first command" if p["wait_for_first_command"] else "")
            )
        )

    def check_params(self, params: dict) -> None:
        steps_per_period(1.0 / params["physics_rate_hz"], 1.0 / params["publish_rate_hz"])
        steps_per_period(1.0 / params["physics_rate_hz"], 1.0 / params["control_rate_hz"])

    def apply_params(self, params: dict, changed: set[str]) -> None:
        if changed & {"physics_rate_hz", "publish_rate_hz", "initial_position", "control_rate_hz"}:
            self.get_logger().warning("physics and publish rates and the initial position apply on restart")

    def effort_callback(self, msg: Float64MultiArray) -> None:
        checked = check_effort(msg.data, self.joint_count)
        if isinstance(checked, str):
            self.warn_throttled("effort", f"/sim/effort dropped: {checked}")
            return
        limit = self.plant.effort_limit
        if np.any(np.abs(checked) > limit):
            self.warn_throttled(
                "effort_limit",
                f"/sim/effort {checked.tolist()} beyond the URDF's effort limit " f"{limit.tolist()}: clamped",
            )
            checked = np.clip(checked, -limit, limit)
        if self.lockstep:
            self.lockstep_effort(checked)
            return
        with self.lock:
            if "estop" in self.brake_reasons:
                self.warn_throttled("estop_effort", "e-stop: efforts ignored until it is released")
                return
            if not self.brake_request_heard and self.count_publishers("/sim/brake"):
                # A motor is there: learn whether it asks for the brakes (its latched
                # state) before any effort releases them.
                self.warn_throttled("brake_state", "efforts ignored until the motor's /sim/brake state arrives")
                return
            if self.anchor_mono_ns is None:
                self.release_brakes()
                self.get_logger().info("first command received, physics running")
            else:
                # Physics up to now ran on the old torque; the new one acts from here.
                self.advance(time.monotonic_ns())
            self.last_effort_mono_ns = time.monotonic_ns()
            self.effort = checked
            self.set_brake("start", False)
            if "drive_timeout" in self.brake_reasons:
                self.get_logger().info("efforts back: brakes released")
            self.set_brake("drive_timeout", False)

    def publish_state(self, stamp_ns: int) -> None:
        position, velocity = self.plant.state()
        msg = self.state_msg
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamp_ns), 1_000_000_000)
        msg.position = position.tolist()
        msg.velocity = velocity.tolist()
        msg.effort = [0.0] * self.joint_count if self.brake_reasons else self.effort.tolist()
        self.state_pub.publish(msg)
        self.publish_disturbance_applied(stamp_ns)

    def finish(self) -> None:
        self.stop_pacing_thread()

    def destroy_node(self) -> None:
        self.finish()
        if self.lockstep:
            self.report_lockstep()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return run(Simulator, args)


if __name__ == "__main__":
    raise SystemExit(main())
