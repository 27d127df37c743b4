"""simulator: the physics world (the Gazebo role). MuJoCo steps the arm
from the URDF at ``physics_rate_hz`` applying the latest ``/sim/effort``;
the true state goes out on ``/sim/joint_states``, stamped with its physics
time.

Wall clock: each timer callback, and each new effort, steps as many physics
steps as the clock says are due, so the sim keeps real time even if a
callback is late and a new torque acts from the physics step it arrived in,
whatever the publish rate.

Lockstep (``lockstep: true``, sim time): the sim owns time. It publishes
``/clock`` and the state for tick k, then waits; the effort for tick k
advances exactly one control period. No effort, no time: a run is
deterministic and as fast as the graph can go.
"""
from __future__ import annotations

import numpy as np
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from robot_controller import config as cfg
from robot_controller import resources
from robot_controller.core.plant import MujocoPlant, steps_per_period
from robot_controller.core.validation import check_effort
from robot_controller.nodes.base import CONTROL_QOS, ConsumerWatch, StackNode, run

# Catch up at most this many physics steps in one callback; beyond, the sim
# runs slower than real time rather than jumping.
MAX_CATCH_UP_STEPS = 100


class Simulator(StackNode):
    def __init__(self) -> None:
        super().__init__("simulator")
        p = self.params
        self.plant = MujocoPlant(resources.resolve_urdf(p["urdf_path"]), 1.0 / p["physics_rate_hz"])
        self.joint_count = len(self.plant.joint_names)
        self.plant.reset(cfg.per_joint("initial_position", p["initial_position"], self.joint_count))
        self.effort = np.zeros(self.joint_count)
        self.steps_done = 0
        self.physics_dt_ns = round(self.plant.physics_dt * 1e9)
        self.anchor_ns: int | None = None  # ROS time of physics time 0 (wall clock)
        self.behind_warned = False
        self.lockstep = p["lockstep"]
        self.efforts_applied = 0
        self.ticks_published = 0

        self.state_pub = self.create_publisher(JointState, "/sim/joint_states", CONTROL_QOS)
        self.create_subscription(Float64MultiArray, "/sim/effort", self.effort_callback, CONTROL_QOS)
        self.state_msg = JointState()
        self.state_msg.name = list(self.plant.joint_names)
        if self.lockstep:
            self.steps_per_tick = steps_per_period(self.plant.physics_dt, 1.0 / p["control_rate_hz"])
            self.clock_pub = self.create_publisher(ClockMsg, "/clock", CONTROL_QOS)
            self.clock_msg = ClockMsg()
            self.waiting_for_effort = False
            self.sensor_watch = ConsumerWatch(self, "/sim/joint_states")
            self.start_poll = self.create_timer(0.05, self.start_lockstep,
                                                clock=Clock(clock_type=ClockType.STEADY_TIME))
        else:
            self.create_timer(1.0 / p["publish_rate_hz"], self.step_callback)
            if not p["wait_for_first_command"]:
                self.anchor_ns = self.get_clock().now().nanoseconds
        self.get_logger().info(
            f"MuJoCo arm {self.plant.joint_names} at {p['physics_rate_hz']:g} Hz physics, "
            + (f"lockstep at {p['control_rate_hz']:g} Hz on /clock" if self.lockstep else
               f"true state at {p['publish_rate_hz']:g} Hz"
               + (", waiting for the first command" if p["wait_for_first_command"] else "")))

    def check_params(self, params: dict) -> None:
        steps_per_period(1.0 / params["physics_rate_hz"], 1.0 / params["publish_rate_hz"])
        steps_per_period(1.0 / params["physics_rate_hz"], 1.0 / params["control_rate_hz"])

    def apply_params(self, params: dict, changed: set[str]) -> None:
        if changed & {"physics_rate_hz", "publish_rate_hz", "initial_position", "control_rate_hz"}:
            self.get_logger().warning("physics and publish rates and the initial position apply on restart")

    # --- effort in ------------------------------------------------------------

    def effort_callback(self, msg: Float64MultiArray) -> None:
        checked = check_effort(msg.data, self.joint_count)
        if isinstance(checked, str):
            self.warn_throttled("effort", f"/sim/effort dropped: {checked}")
            return
        if self.lockstep:
            self.lockstep_effort(checked)
            return
        if self.anchor_ns is not None:
            # Physics up to now ran on the old torque; the new one acts from here.
            self.advance(self.get_clock().now().nanoseconds)
        self.effort = checked
        if self.anchor_ns is None:
            # Brakes off: physics time 0 is now.
            self.anchor_ns = self.get_clock().now().nanoseconds
            self.get_logger().info("first command received, physics running")

    # --- wall clock -------------------------------------------------------------

    def step_callback(self) -> None:
        now_ns = self.get_clock().now().nanoseconds
        if self.anchor_ns is None:
            self.publish_state(now_ns)
            return
        self.advance(now_ns)
        self.publish_state(self.anchor_ns + self.steps_done * self.physics_dt_ns)

    def advance(self, now_ns: int) -> None:
        """Step the physics that the clock says is due by ``now_ns``."""
        due = (now_ns - self.anchor_ns) // self.physics_dt_ns - self.steps_done
        if due <= 0:
            return
        if due > MAX_CATCH_UP_STEPS:
            if not self.behind_warned:
                self.get_logger().warning(f"physics {due} steps behind the clock: slowing below real time")
                self.behind_warned = True
            self.anchor_ns += (due - MAX_CATCH_UP_STEPS) * self.physics_dt_ns
            due = MAX_CATCH_UP_STEPS
        self.plant.step(self.effort, int(due))
        self.steps_done += int(due)

    # --- lockstep ----------------------------------------------------------------

    def start_lockstep(self) -> None:
        """Publish tick 0 once the sensor listens and the motor talks (nothing is ever re-sent)."""
        if not (self.sensor_watch.ready() and self.get_publishers_info_by_topic("/sim/effort")):
            return
        self.destroy_timer(self.start_poll)
        self.get_logger().info("lockstep: sensor and motor matched, starting at t = 0")
        self.publish_tick()

    def lockstep_effort(self, effort: np.ndarray) -> None:
        if not self.waiting_for_effort:
            self.warn_throttled("extra_effort", "lockstep: effort with no tick waiting for it, ignored")
            return
        self.waiting_for_effort = False
        self.effort = effort
        self.efforts_applied += 1
        self.plant.step(effort, self.steps_per_tick)
        self.steps_done += self.steps_per_tick
        self.publish_tick()

    def publish_tick(self) -> None:
        stamp_ns = self.steps_done * self.physics_dt_ns
        self.clock_msg.clock.sec, self.clock_msg.clock.nanosec = divmod(stamp_ns, 1_000_000_000)
        self.clock_pub.publish(self.clock_msg)
        self.waiting_for_effort = True
        self.ticks_published += 1
        self.publish_state(stamp_ns)

    def publish_state(self, stamp_ns: int) -> None:
        position, velocity = self.plant.state()
        msg = self.state_msg
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamp_ns), 1_000_000_000)
        msg.position = position.tolist()
        msg.velocity = velocity.tolist()
        msg.effort = self.effort.tolist()
        self.state_pub.publish(msg)

    def destroy_node(self) -> None:
        if self.lockstep:
            self.get_logger().info(f"lockstep: {self.ticks_published} ticks published, {self.efforts_applied} "
                                   f"efforts applied, t = {self.steps_done * self.plant.physics_dt:.3f} s")
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return run(Simulator, args)


if __name__ == "__main__":
    raise SystemExit(main())
