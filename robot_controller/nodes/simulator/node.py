"""The simulator node: the host of the world block (``blocks.world``) and of the clock that steps it
(``ros.clocks``), chosen once at start (``ros.ticks``). It turns the world's ports into
topics (``blocks.spec``), serves the e-stop button and, in sim time, follows the recorder's clock."""

from __future__ import annotations

import os
from typing import Any

from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64MultiArray, MultiArrayDimension
from std_srvs.srv import SetBool

from robot_controller.blocks import spec
from robot_controller.blocks.world import World, Written
from robot_controller.nodes.world_state import WORLD_STATE_ENV, WorldState
from robot_controller.ros.adapter import NodeLog
from robot_controller.ros.clocks.outlets import Outlets
from robot_controller.ros.messages import command_tick_s, decode, message_class
from robot_controller.ros.process import run
from robot_controller.ros.publishing import COUNTS_DIR_ENV, recorded
from robot_controller.ros.qos import CLOCK_QOS, profile
from robot_controller.ros.stack_node import StackNode
from robot_controller.ros.ticks import ClockMode, tick_source_class

#: How often, s (steady clock), sim time looks whether the graph is ready for tick 0.
START_POLL_S = 0.05


class Simulator(StackNode):
    def __init__(self) -> None:
        super().__init__("simulator")
        p = self.params
        self.world = world = World(p, NodeLog(self), world_waits=self.mode.world_waits)
        n = world.joint_count
        state_file = WorldState.open(os.environ.get(WORLD_STATE_ENV, ""), n)
        if state_file is not None and state_file.resumed is not None:
            world.respawn(state_file.resumed)
        self.state_pub = self.gated_publisher(JointState, spec.TRUE_STATE.topic)
        self.state_msg = JointState(name=world.joint_names)
        self.brakes_pub = self.gated_publisher(Float64MultiArray, spec.BRAKES.topic, consumer=False)
        self.brakes_msg = Float64MultiArray()
        self.brakes_msg.layout.dim = [MultiArrayDimension(label="engaged", size=n, stride=n)]
        self.applied_pub = self.gated_publisher(Float64MultiArray, spec.DISTURBANCE_APPLIED.topic, consumer=False)
        self.applied_msg = Float64MultiArray()
        self.applied_msg.layout.dim = [
            MultiArrayDimension(label="torque_nm", size=n, stride=n),
            MultiArrayDimension(label="time_s", size=1, stride=1),
        ]
        self.clock_pub = self.clock_msg = None
        if self.mode.world_waits:
            self.clock_pub = self.gated_publisher(ClockMsg, spec.CLOCK.topic, consumer=False, qos=CLOCK_QOS)
            self.clock_msg = ClockMsg()
        self.effort_sub = self.subscribe(spec.EFFORT, self.effort_callback)
        self.watch_single_publisher(spec.EFFORT.topic, spec.EFFORT.writer)
        self.subscribe(spec.BRAKE_REQUEST, self.brake_request_callback)
        self.subscribe(spec.ESTOP, lambda msg: self.set_estop(bool(msg.data)))
        self.subscribe(spec.DISTURBANCE, self.disturbance_callback)
        self.create_service(SetBool, spec.ESTOP_SERVICE.service, self.estop_service)
        out = Outlets(
            write=self.write,
            write_state=self.write_state,
            state_open=lambda: self.state_pub.open,
            write_clock=self.write_clock,
            ready=self.graph_ready,
            ros_now_ns=lambda: self.get_clock().now().nanoseconds,
            motor_present=lambda: bool(self.count_publishers(spec.BRAKE_REQUEST.topic)),
            save_position=None if state_file is None else state_file.save,
        )
        log = NodeLog(self)
        sim_time = {} if self.mode is ClockMode.WALL else {"recorded": recorded()}
        self.clock = tick_source_class(self.get_name(), self.mode)(world, p, out, log, **sim_time)
        if self.mode.world_waits:
            if recorded():
                self.subscribe(spec.RECORDER_CLOCK, self.recorder_clock_callback)
            self.start_poll = self.create_timer(
                START_POLL_S, self.try_start, clock=Clock(clock_type=ClockType.STEADY_TIME)
            )
        self.clock.start()
        self.get_logger().info(
            f"MuJoCo arm {world.joint_names} at {p['physics_rate_hz']:g} Hz physics, {self.clock.describe(p)}"
        )

    def subscribe(self, port: spec.Port, callback: Any) -> Any:
        """A reader of ``port`` with the QoS its class has in this clock mode."""
        qos = profile(port.qos, world_waits=self.mode.world_waits)
        return self.create_subscription(message_class(port.msg_type), port.topic, callback, qos)

    def check_params(self, params: dict) -> None:
        World.check_params(params)  # before the world exists, too

    def apply_params(self, params: dict, changed: set[str]) -> None:
        self.world.set_params(params, changed)

    # --- the world's inputs -----------------------------------------------------------------------------------------

    def effort_callback(self, msg: Float64MultiArray) -> None:
        effort = self.world.check_effort(decode(msg))
        if effort is None:
            return
        tick_s = command_tick_s(msg)  # the drive passes the controller's tick on
        self.clock.take_effort(effort, None if tick_s is None else round(tick_s * 1e9))

    def brake_request_callback(self, msg: Bool) -> None:
        with self.clock.lock:
            self.write(self.world.take_brake_request(bool(msg.data)))

    def estop_service(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        self.set_estop(bool(request.data))
        response.success = True
        response.message = "e-stop engaged: torque off, brakes on" if request.data else "e-stop released"
        return response

    def set_estop(self, on: bool) -> None:
        with self.clock.lock:
            if on == self.world.estopped:
                return  # said again (the button repeats it): nothing changes
            self.clock.catch_up()  # the physics up to now ran without it
            self.write(self.world.take_estop(on))
        if not on:
            with self.clock.lock:  # released, the brakes wait for the drive's next effort
                self.write(self.world.set_brake("drive_timeout", True))

    def disturbance_callback(self, msg: Float64MultiArray) -> None:
        with self.clock.lock:
            self.clock.catch_up()  # the physics up to now ran without it
            self.world.take_disturbance(decode(msg), physics_running=self.clock.physics_running)

    def recorder_clock_callback(self, msg: ClockMsg) -> None:
        self.clock.recorder_at(msg.clock.sec * 1_000_000_000 + msg.clock.nanosec)

    def try_start(self) -> None:
        if self.clock.try_start():
            self.destroy_timer(self.start_poll)

    def graph_ready(self) -> bool:
        """Sim time's tick 0: the sensor (and recorder) listen and the drive matched (not only named in the graph: a
        drive of an earlier run can linger there)."""
        return self.state_pub.open and self.clock_pub.open and bool(self.effort_sub.get_publisher_count())

    # --- the world's outputs ----------------------------------------------------------------------------------------

    def write(self, written: Written) -> None:
        for name, value in written:
            if name == "brakes":
                self.brakes_msg.data = value.data.tolist()
                self.brakes_msg.layout.dim[0].label = value.label
                self.brakes_pub.publish(self.brakes_msg)
            elif name == "disturbance_applied":
                self.applied_msg.data = value.data.tolist()
                self.applied_pub.publish(self.applied_msg)

    def write_state(self, stamp_ns: int) -> None:
        """The true state stamped ``stamp_ns`` (exact: a wall clock's stamp is too large for a float's ns)."""
        written = self.world.sample(stamp_ns * 1e-9)
        sample = written[0][1]
        msg = self.state_msg
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamp_ns), 1_000_000_000)
        msg.position = sample.position.tolist()
        msg.velocity = sample.velocity.tolist()
        msg.effort = sample.effort.tolist()
        self.state_pub.publish(msg)
        self.write(written[1:])

    def write_clock(self, stamp_ns: int) -> None:
        self.clock_msg.clock.sec, self.clock_msg.clock.nanosec = divmod(stamp_ns, 1_000_000_000)
        self.clock_pub.publish(self.clock_msg)

    def finish(self) -> None:
        self.clock.stop(os.environ.get(COUNTS_DIR_ENV, ""))

    def destroy_node(self) -> None:
        self.finish()
        self.clock.report()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return run(Simulator, args)
