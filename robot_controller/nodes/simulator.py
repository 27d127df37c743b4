"""simulator: the physics world (the Gazebo role), the world block (``blocks.world``) hosted by the adapter
(``ros.adapter``) and stepped by the world's clock (``ros.clocks``, chosen once by ``ros.ticks``); beside it, its true
state stamped to the ns, the sim's clock where the world waits, the e-stop button (a service), the recorder's clock
followed and the start held until the graph is ready, and the arm's position in a memory-mapped file (written on every
pacing tick, no system call), so that a respawned simulator finds the arm where it was."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg
from std_srvs.srv import SetBool

from robot_controller.blocks import spec
from robot_controller.blocks.block import Block
from robot_controller.blocks.world import World, Written
from robot_controller.ros.adapter import BlockNode, Extras
from robot_controller.ros.clocks.host import Outlets
from robot_controller.ros.process import run
from robot_controller.ros.publishing import recorded
from robot_controller.ros.qos import CLOCK_QOS
from robot_controller.ros.ticks import ClockMode

#: How often, s (steady clock), sim time looks whether the graph is ready for tick 0.
START_POLL_S = 0.05

# Set by the launcher (with --respawn) to the file's path.
WORLD_STATE_ENV = "ROBOT_CONTROLLER_WORLD_STATE"

# [valid flag, position per joint]
_VALID = 1.0


class WorldState:
    def __init__(self, array: np.memmap, resumed: np.ndarray | None) -> None:
        self._array = array
        self.resumed = resumed  #: the positions found at start (a respawn), or None

    @classmethod
    def open(cls, path: str, joint_count: int) -> WorldState | None:
        """The state file at ``path`` (None: no path); one left by an earlier simulator gives ``resumed``."""
        if not path:
            return None
        file = Path(path)
        size = (1 + joint_count) * 8
        resumed = None
        if file.is_file() and file.stat().st_size == size:
            previous = np.fromfile(file, dtype=np.float64)
            if previous[0] == _VALID and np.all(np.isfinite(previous[1:])):
                resumed = previous[1:].copy()
        else:
            file.write_bytes(b"\0" * size)
        return cls(np.memmap(file, dtype=np.float64, mode="r+", shape=(1 + joint_count,)), resumed)

    def save(self, position: np.ndarray) -> None:
        self._array[1:] = position
        self._array[0] = _VALID


class WorldExtras(Extras):
    def make_block(self, params: dict[str, Any], world_waits: bool) -> Block:
        return World(params, self.node, world_waits=world_waits)

    def watched(self, port: spec.Port) -> bool:
        return port.name == "effort"

    def consumer(self, port: spec.Port) -> bool:
        return port.name == "true_state"  # the brakes and the push applied are telemetry

    def layout(self, port: spec.Port) -> list[tuple[str, int]] | None:
        n = self.node.block.joint_count
        return {"brakes": [("engaged", n)], "disturbance_applied": [("torque_nm", n), ("time_s", 1)]}.get(port.name)

    def make_ticks(self, source: type) -> Any:
        node, world = self.node, self.node.block
        state_file = WorldState.open(os.environ.get(WORLD_STATE_ENV, ""), world.joint_count)
        if state_file is not None and state_file.resumed is not None:
            world.respawn(state_file.resumed)
        self.clock_pub = self.clock_msg = None
        if node.mode.world_waits:
            self.clock_pub = node.gated_publisher(ClockMsg, spec.CLOCK.topic, consumer=False, qos=CLOCK_QOS)
            self.clock_msg = ClockMsg()
        self.state_pub, state_msg = node.publishers_by_port["true_state"]
        state_msg.name = world.joint_names
        out = Outlets(
            write=self.write_values,
            write_state=self.write_state,
            state_open=lambda: self.state_pub.open,
            write_clock=self.write_clock,
            ready=self.graph_ready,
            ros_now_ns=lambda: node.get_clock().now().nanoseconds,
            motor_present=lambda: bool(node.count_publishers(spec.BRAKE_REQUEST.topic)),
            save_position=None if state_file is None else state_file.save,
        )
        sim_time = {} if node.mode is ClockMode.WALL else {"recorded": recorded()}
        return source(world, node.params, out, node, **sim_time)

    def start(self) -> None:
        node = self.node
        node.create_service(SetBool, spec.ESTOP_SERVICE.service, self.estop_service)
        if node.mode.world_waits:
            if recorded():
                node.create_subscription(
                    ClockMsg,
                    spec.RECORDER_CLOCK.topic,
                    lambda msg: node.ticks.recorder_at(msg.clock.sec * 1_000_000_000 + msg.clock.nanosec),
                    self.reader_qos(spec.RECORDER_CLOCK),
                )
            self.start_poll = node.create_timer(
                START_POLL_S, self.try_start, clock=Clock(clock_type=ClockType.STEADY_TIME)
            )
        p = node.params
        node.get_logger().info(
            f"MuJoCo arm {node.block.joint_names} at {p['physics_rate_hz']:g} Hz physics, {node.ticks.describe(p)}"
        )

    def estop_service(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        self.node.ticks.take("estop", bool(request.data))
        response.success = True
        response.message = "e-stop engaged: torque off, brakes on" if request.data else "e-stop released"
        return response

    def try_start(self) -> None:
        if self.node.ticks.try_start():
            self.node.destroy_timer(self.start_poll)

    def graph_ready(self) -> bool:
        """Sim time's tick 0: the sensor (and recorder) listen and the drive matched (not only named in the graph: a
        drive of an earlier run can linger there)."""
        effort_sub = self.node.subscriptions_by_port["effort"]
        return self.state_pub.open and self.clock_pub.open and bool(effort_sub.get_publisher_count())

    def write_values(self, written: Written) -> None:
        for name, value in written:
            if name in ("brakes", "disturbance_applied"):
                self.node.publish({name: value})

    def write_state(self, stamp_ns: int) -> None:
        """The true state stamped ``stamp_ns`` (exact: a wall clock's stamp is too large for a float's ns)."""
        written = self.node.block.sample(stamp_ns * 1e-9)
        sample = written[0][1]
        publisher, msg = self.node.publishers_by_port["true_state"]
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(int(stamp_ns), 1_000_000_000)
        msg.position = sample.position.tolist()
        msg.velocity = sample.velocity.tolist()
        msg.effort = sample.effort.tolist()
        publisher.publish(msg)
        self.write_values(written[1:])

    def write_clock(self, stamp_ns: int) -> None:
        self.clock_msg.clock.sec, self.clock_msg.clock.nanosec = divmod(stamp_ns, 1_000_000_000)
        self.clock_pub.publish(self.clock_msg)

    def destroy(self) -> None:
        self.node.ticks.finish()


def Simulator() -> BlockNode:  # noqa: N802 (made as a node class is, by ``ros.process.run``)
    return BlockNode("simulator", WorldExtras)


def main(args: list[str] | None = None) -> int:
    return run(Simulator, args)


if __name__ == "__main__":
    raise SystemExit(main())
