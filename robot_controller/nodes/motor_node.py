"""motor_node: the actuator. Each ``/joint_commands`` torque is saturated to ``±torque_max`` (and lagged, if set) and
passed on as ``/sim/effort``; one older than ``max_command_age_s`` is dropped. Like a drive it stops on its own (no
valid command for ``command_timeout_s``, or ``/estop``): zero torque and a brake request (``/sim/brake``). Receipts go
out once a second on ``/motor/command_receipts``, rows of ``[receipt_time_s, command…]``."""

from __future__ import annotations

import numpy as np
from std_msgs.msg import Bool, Float64MultiArray, MultiArrayDimension

from robot_controller import resources
from robot_controller.core.errors import ConfigError
from robot_controller.core.metrics import EFFORT_UNITS, in_units
from robot_controller.core.model import Actuator, effort_limits, joint_names, load_model
from robot_controller.core.model.mujoco_model import joint_units
from robot_controller.parameters.torque_limits import torque_limit
from robot_controller.ros.messages import check_effort, clock_s, command_tick_s, stamp_command
from robot_controller.ros.process import run
from robot_controller.ros.qos import ESTOP_QOS, LATCHED_QOS, loop_qos
from robot_controller.ros.stack_node import StackNode

RECEIPTS_PERIOD_S = 1.0
# The motor's own pause up to this long (a machine-wide stall) is not counted as the controller's silence.
MAX_EXCUSED_GAP_S = 0.2
# Stopped for a timeout (or before the first command), the drive restarts after this many timely commands in a row.
TIMELY_COMMANDS_TO_START = 5


class MotorNode(StackNode):
    def __init__(self) -> None:
        super().__init__("motor_node")
        self.actuator = self._make_actuator(self.params)
        self.last_command_s: float | None = None
        self.effort_pub = self.gated_publisher(Float64MultiArray, "/sim/effort")
        self.create_subscription(Float64MultiArray, "/joint_commands", self.command_callback, loop_qos(self.lockstep))
        self.watch_single_publisher("/joint_commands", "pid_controller")
        # Category 0 on lost commands or e-stop: zero torque and the simulator's brakes.
        self.brake_pub = self.gated_publisher(Bool, "/sim/brake", qos=LATCHED_QOS)
        self.stopped_for: str | None = None  # "timeout" or "estop" while stopped
        self.estop = False
        self.create_subscription(Bool, "/estop", self.estop_callback, ESTOP_QOS)
        if not self.lockstep:  # in lockstep no time passes between ticks: the sim waits for each command
            self.create_timer(self.params["command_timeout_s"] / 2, self.timeout_check)
        self.last_check_s = clock_s(self)
        self.timely_run = 0  #: timely commands in a row while stopped for a timeout or before the first
        self.excused_s = 0.0  #: of the silence since the last command, time this process itself was not running
        self.request_brake(False)  # the request's state is latched: a (re)started simulator learns it
        self.effort_msg = Float64MultiArray()
        self.receipts: list[float] = []  # flat rows of [receipt_time_s, command…]
        self.receipts_pub = self.gated_publisher(Float64MultiArray, "/motor/command_receipts", consumer=False)
        self.create_timer(RECEIPTS_PERIOD_S, self.publish_receipts)
        self.get_logger().info(
            f"motor: torque limit ±{in_units(self.actuator.torque_max, self.effort_units)}, "
            f"lag {self.actuator.lag_time_constant_s:g} s"
        )

    def _make_actuator(self, params: dict) -> Actuator:
        torque_max = torque_limit(params, self.joint_count)
        if np.any(torque_max > self.effort_limit):
            raise ConfigError(
                f"torque_max: {in_units(torque_max, self.effort_units)} exceeds the URDF's effort limit "
                f"{in_units(self.effort_limit, self.effort_units)} (it may lower the drive's limit, never raise it)"
            )
        return Actuator(torque_max, params["lag_time_constant_s"])

    def setup(self, params: dict) -> None:
        model = load_model(resources.resolve_urdf(params["urdf_path"]))
        self.joint_names = joint_names(model)
        self.joint_count = len(self.joint_names)
        self.effort_limit = effort_limits(model)
        self.effort_units = [EFFORT_UNITS[unit] for unit in joint_units(model)]  # N·m, or N on a prismatic joint

    def check_params(self, params: dict) -> None:
        self._make_actuator(params)

    def apply_params(self, params: dict, changed: set[str]) -> None:
        self.actuator = self._make_actuator(params)

    def command_callback(self, msg: Float64MultiArray) -> None:
        checked = check_effort(msg.data, self.joint_count)
        if isinstance(checked, str):
            return self.drop("/joint_commands", checked)
        if self.estop:
            return
        tick_s = command_tick_s(msg)
        if self.lockstep and tick_s is None:  # a controller not ours: applied, its time the wall clock's
            self.warn_throttled(
                "unstamped_command",
                "lockstep: /joint_commands carry no tick stamp: the lag and the receipts run on the wall clock",
            )
        now_s = tick_s if self.lockstep and tick_s is not None else clock_s(self)
        self.receipts.append(now_s)  # a late command too: its delay is what the controller must learn
        self.receipts.extend(msg.data)
        if not self.lockstep and tick_s is not None and now_s - tick_s > self.params["max_command_age_s"]:
            self.warn_throttled(
                "late_command",
                f"/joint_commands dropped: issued {(now_s - tick_s) * 1e3:.0f} ms ago "
                f"(max_command_age_s {self.params['max_command_age_s']:g}): a late command is no command",
            )
            self.timely_run = 0
            return
        if not self.lockstep and (self.stopped_for == "timeout" or self.last_command_s is None):
            # Stopped (or not started): only a steady stream of timely commands moves the arm.
            self.timely_run += 1
            if self.timely_run < TIMELY_COMMANDS_TO_START:
                return
        self.timely_run = 0
        if self.stopped_for == "timeout":
            self.get_logger().info("commands back: brake request released")
            self.request_brake(False)
            self.stopped_for = None
        dt = 0.0 if self.last_command_s is None else now_s - self.last_command_s
        self.last_command_s = now_s
        self.excused_s = 0.0
        applied = self.actuator.apply(checked, dt)
        self.effort_msg.data = applied.tolist()
        if self.lockstep and tick_s is not None:  # the tick goes on: a paced world drops an effort come too late
            stamp_command(self.effort_msg, tick_s)
        else:
            self.effort_msg.layout.dim = []
        self.effort_pub.publish(self.effort_msg)

    def timeout_check(self) -> None:
        now_s = clock_s(self)
        own_gap_s, self.last_check_s = now_s - self.last_check_s, now_s
        if self.stopped_for is not None or self.last_command_s is None:
            return  # already stopped, or no command yet (the brakes are on from start-up)
        check_period_s = self.params["command_timeout_s"] / 2
        if 2 * check_period_s < own_gap_s <= MAX_EXCUSED_GAP_S:
            # This process was not running: the commands the pause held back are on their way, not silent.
            self.excused_s += own_gap_s - check_period_s
        silent_s = now_s - self.last_command_s - self.excused_s
        if silent_s > self.params["command_timeout_s"]:
            warning = f"no valid /joint_commands for {silent_s * 1e3:.0f} ms: zero torque, brake requested (category 0)"
            self.get_logger().warning(warning)
            self.stop("timeout")

    def stop(self, reason: str) -> None:
        self.stopped_for = reason
        self.actuator.reset()
        self.request_brake(True)  # before the zero torque: it must never reach an unbraked, gravity-loaded arm
        self.effort_msg.data = [0.0] * self.joint_count
        self.effort_msg.layout.dim = []  # the stop's own torque: no tick's command
        self.effort_pub.publish(self.effort_msg)

    def request_brake(self, on: bool) -> None:
        self.brake_pub.publish(Bool(data=on))

    def estop_callback(self, msg: Bool) -> None:
        if bool(msg.data) == self.estop:
            return
        self.estop = bool(msg.data)
        if self.estop:
            self.get_logger().warning("E-STOP: zero torque, brake requested (latched until released)")
            self.stop("estop")
        else:
            self.get_logger().info("e-stop released: forwarding commands again")
            self.request_brake(False)
            self.stopped_for = None
            self.last_command_s = None

    def publish_receipts(self) -> None:
        if not self.receipts:
            return
        row = 1 + self.joint_count
        msg = Float64MultiArray()
        msg.layout.dim = [
            MultiArrayDimension(label="commands", size=len(self.receipts) // row, stride=len(self.receipts)),
            MultiArrayDimension(label="receipt_time_s,command", size=row, stride=row),
        ]
        msg.data = self.receipts
        self.receipts = []
        self.receipts_pub.publish(msg)

    def finish(self) -> None:
        self.publish_receipts()  # the last second's


def main(args: list[str] | None = None) -> int:
    return run(MotorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
