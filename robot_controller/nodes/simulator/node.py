"""The simulator node: the plant, the effort taken in and the true state sent out; its parts (``pacing``
or ``ticks``, ``brakes``, ``disturbance``) share its plant, effort and lock."""

from __future__ import annotations

import os
import threading
import time

import numpy as np
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.blocks import spec
from robot_controller.core.model import MujocoPlant, PlantVariation, steps_per_period
from robot_controller.nodes.simulator.brakes import Brakes
from robot_controller.nodes.simulator.disturbance import Disturbance
from robot_controller.nodes.simulator.lockstep import LockstepTicks
from robot_controller.nodes.simulator.paced import PacedTicks
from robot_controller.nodes.simulator.pacing import Pacing
from robot_controller.nodes.world_state import WORLD_STATE_ENV, WorldState
from robot_controller.ros.messages import check_effort, command_tick_s
from robot_controller.ros.process import run
from robot_controller.ros.publishing import COUNTS_DIR_ENV
from robot_controller.ros.qos import loop_qos
from robot_controller.ros.stack_node import StackNode


class Simulator(StackNode):
    def __init__(self) -> None:
        super().__init__("simulator")
        p = self.params
        variation = PlantVariation.from_params(p)
        self.plant = MujocoPlant(
            resources.resolve_urdf(p["urdf_path"]), 1.0 / p["physics_rate_hz"], variation=variation
        )
        self.joint_count = len(self.plant.joint_names)
        self.plant.reset(cfg.per_joint("initial_position", p["initial_position"], self.joint_count))
        self.world = WorldState.open(os.environ.get(WORLD_STATE_ENV, ""), self.joint_count)
        if self.world is not None and self.world.resumed is not None:
            self.plant.reset(self.world.resumed)
            warning = f"respawned: the arm is where it was, at {self.world.resumed.tolist()} rad"
            self.get_logger().warning(f"{warning}, brakes on until the first command")
        self.effort = np.zeros(self.joint_count)
        self.said_brake_wait = False  # the start's wait for the motor's brake request, said once
        self.steps_done = 0
        self.physics_dt_ns = round(self.plant.physics_dt * 1e9)
        self.lock = threading.Lock()  # the plant and effort: pacing thread vs the executor's callbacks
        self.pacing = None if self.lockstep else Pacing(self)
        self.state_pub = self.gated_publisher(JointState, spec.TRUE_STATE.topic)
        self.effort_sub = self.create_subscription(
            Float64MultiArray, spec.EFFORT.topic, self.effort_callback, loop_qos(self.lockstep)
        )
        self.watch_single_publisher(spec.EFFORT.topic, spec.EFFORT.writer)
        self.brakes = Brakes(self)
        self.state_msg = JointState()
        self.state_msg.name = list(self.plant.joint_names)
        self.disturbance = Disturbance(self)
        self.ticks: LockstepTicks | PacedTicks | None = None
        if self.lockstep:
            self.ticks = PacedTicks(self) if p["real_time_factor"] > 0 else LockstepTicks(self)
        if self.pacing is not None:
            self.pacing.start()
        self.get_logger().info(
            f"MuJoCo arm {self.plant.joint_names} at {p['physics_rate_hz']:g} Hz physics, "
            + (
                f"lockstep at {p['control_rate_hz']:g} Hz on {spec.CLOCK.topic}"
                + (f", paced at {p['real_time_factor']:g}× the wall clock" if p["real_time_factor"] > 0 else "")
                if self.lockstep
                else f"true state at {p['publish_rate_hz']:g} Hz, paced on absolute deadlines"
                + (", brakes on until the first command" if p["wait_for_first_command"] else "")
            )
        )
        if not variation.nominal:
            self.get_logger().info(f"the plant differs from its URDF: {variation.describe()}")

    def check_params(self, params: dict) -> None:
        PlantVariation.from_params(params)  # one payload, not two; every value finite and in range
        steps_per_period(1.0 / params["physics_rate_hz"], 1.0 / params["publish_rate_hz"])
        steps_per_period(1.0 / params["physics_rate_hz"], 1.0 / params["control_rate_hz"])

    def apply_params(self, params: dict, changed: set[str]) -> None:
        if changed & {"physics_rate_hz", "publish_rate_hz", "initial_position", "control_rate_hz"}:
            self.get_logger().warning("physics and publish rates and the initial position apply on restart")

    def step(self, steps: int) -> None:
        """Step the physics ``steps`` times on the effort in force (lock held)."""
        self.disturbance.start_scheduled()
        self.plant.step(self.effort, steps)
        self.steps_done += steps
        self.disturbance.note_end()

    def catch_up(self) -> None:
        """Wall clock, physics running: step what is due by now on the old inputs (lock held)."""
        if self.pacing is not None and self.pacing.running:
            self.pacing.advance(time.monotonic_ns())

    def effort_callback(self, msg: Float64MultiArray) -> None:
        checked = check_effort(msg.data, self.joint_count)
        if isinstance(checked, str):
            return self.drop(spec.EFFORT.topic, checked)
        limit = self.plant.effort_limit
        if np.any(np.abs(checked) > limit):
            self.warn_throttled(
                "effort_limit",
                f"{spec.EFFORT.topic} {checked.tolist()} beyond the URDF's effort limit {limit.tolist()}: clamped",
            )
            checked = np.clip(checked, -limit, limit)
        if isinstance(self.ticks, PacedTicks):
            tick_s = command_tick_s(msg)  # the motor passes the controller's tick on
            self.ticks.take_effort(checked, None if tick_s is None else round(tick_s * 1e9))
            return
        if self.ticks is not None:
            self.ticks.take_effort(checked)
            return
        brakes = self.brakes
        with self.lock:
            if "estop" in brakes.reasons:
                self.warn_throttled("estop_effort", "e-stop: efforts ignored until it is released")
                return
            if not brakes.request_heard and self.count_publishers(spec.BRAKE_REQUEST.topic):
                # A motor is there: its latched brake request comes before any effort releases the brakes. The
                # two race at the start (a respawned simulator's too): normal, said once.
                if not self.said_brake_wait:
                    self.said_brake_wait = True
                    self.get_logger().info(
                        f"efforts wait for the motor's latched {spec.BRAKE_REQUEST.topic} state (the start's race)"
                    )
                return
            if not self.pacing.running:
                self.pacing.begin()
                self.get_logger().info("first command received, physics running")
            else:
                self.catch_up()  # the new torque acts from here
            brakes.last_effort_mono_ns = time.monotonic_ns()
            self.effort = checked
            brakes.set("start", False)
            if "drive_timeout" in brakes.reasons:
                self.get_logger().info("efforts back: brakes released")
            brakes.set("drive_timeout", False)

    def publish_state(self, stamp_ns: int) -> None:
        position, velocity = self.plant.state()
        msg = self.state_msg
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamp_ns), 1_000_000_000)
        msg.position = position.tolist()
        msg.velocity = velocity.tolist()
        msg.effort = [0.0] * self.joint_count if self.brakes.reasons else self.effort.tolist()
        self.state_pub.publish(msg)
        self.disturbance.publish_applied(stamp_ns)

    def finish(self) -> None:
        counts_dir = os.environ.get(COUNTS_DIR_ENV, "")
        if self.pacing is not None:
            self.pacing.stop(counts_dir)
        if isinstance(self.ticks, PacedTicks):
            self.ticks.stop(counts_dir)

    def destroy_node(self) -> None:
        self.finish()
        if self.ticks is not None:
            self.ticks.report()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return run(Simulator, args)
