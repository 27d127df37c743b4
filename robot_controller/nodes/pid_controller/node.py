"""The controller node: the inputs, the triggers (a timer, ``trigger: measurement``, or lockstep
pairing), the tick and its published torque; every decision about torque is in the core.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64MultiArray

from robot_controller import parameters as cfg
from robot_controller.blocks import spec
from robot_controller.core.controller import JointController, Status
from robot_controller.core.errors import ConfigError
from robot_controller.core.laws import parameters as law_parameters
from robot_controller.core.laws import registry
from robot_controller.core.laws.containment import BLOCKED_S
from robot_controller.nodes.pid_controller import live_gains, log_line
from robot_controller.nodes.pid_controller.designer import Designer
from robot_controller.nodes.pid_controller.status import StartWaits, StatusReports
from robot_controller.nodes.pid_controller.timing import LoopTiming
from robot_controller.parameters import law_params
from robot_controller.parameters.builders import arm_model, model_overridden
from robot_controller.ros.loop_processes import thread_kept_s
from robot_controller.ros.messages import (
    brake_reasons,
    check_joint_state,
    check_trajectory,
    clock_s,
    stamp_command,
    stamp_to_s,
)
from robot_controller.ros.process import run
from robot_controller.ros.qos import ESTOP_QOS, LATCHED_QOS, LATEST_QOS, LOCKSTEP_READINGS_READER_QOS, loop_qos
from robot_controller.ros.stack_node import StackNode

# Readings naming other joints for this long, none usable yet: a configuration mismatch.
CONFIG_MISMATCH_S = 2.0
# The parameters whose change makes the law in force say itself again.
GAIN_KEYS = frozenset({"controller_type", "lqr_q", "lqr_r", "kp", "ki", "kd", "control_rate_hz"})


class PidControllerNode(StackNode):
    def __init__(self) -> None:
        # Its parameter services are live_gains', on a thread of their own (started last, below).
        super().__init__("pid_controller", start_parameter_services=False)
        # A law of one's own is held to its law_budget_s on the time it used. Where the world waits for it
        # (lockstep, the paced world): its thread's CPU time, a call abandoned once blocked for BLOCKED_S of wall
        # time (a law kept from a CPU is not blocked) or once it has computed a period past its budget. On the
        # wall clock: wall time less what the host took from its thread (run-queue wait, steal). There the loop's
        # delay is watched against the gains' delay margin (core.latency).
        self.controller = JointController(
            self.checked.config,  # made from self.params by check_params, which the start ran
            self.joint_count,
            self.dynamics,
            law_clock=time.thread_time if self.lockstep else time.perf_counter,
            latency_guard=not self.lockstep,
            law_run_wait=None if self.lockstep else thread_kept_s,
        )
        if self.lockstep and self.controller.plugin is not None:
            self.controller.plugin.abandon_s = BLOCKED_S
        self.last_tick_s = -np.inf
        self.first_tick_s: float | None = None
        self.log_schedule = log_line.LogSchedule(self.params["log_period_s"])
        self.reference_samples = 0  # usable reference samples so far (two teach the controller the planner's period)
        self.waits = StartWaits(self)
        self.mismatch_since: float | None = None
        self.command_pub = self.gated_publisher(Float64MultiArray, spec.COMMAND.topic)
        self.command_msg = Float64MultiArray()
        self.status = StatusReports(self)
        self.timing = LoopTiming(self)
        readings_qos = LOCKSTEP_READINGS_READER_QOS if self.lockstep else loop_qos(False)
        self.create_subscription(JointState, spec.READING.topic, self.joint_state_callback, readings_qos)
        self.watch_single_publisher(spec.READING.topic, spec.READING.writer)
        self.create_subscription(
            Float64MultiArray, spec.REFERENCE.topic, self.trajectory_callback, loop_qos(self.lockstep)
        )
        self.watch_single_publisher(spec.REFERENCE.topic, spec.REFERENCE.writer)
        self.create_subscription(Bool, spec.ESTOP.topic, lambda msg: self.controller.halt(bool(msg.data)), ESTOP_QOS)
        self.timer = None
        self.timer_period = 0.0
        # The drive's status word: its brakes. While they hold, what is commanded does not move the arm: the
        # reference starts again from the measurement. In lockstep, not the start's: the tick at which the first
        # effort's release arrives is a race, and a run without faults is the same to the bit every time (the
        # paced world's drive-timeout brakes and an e-stop's are heard, at a tick that is a race: a fault's).
        self.create_subscription(Float64MultiArray, spec.BRAKES.topic, self.brakes_callback, LATEST_QOS)
        if self.lockstep:
            self.pairing = LockstepPairing(self)
        else:
            self.pairing = None
            self.set_timer_period(self.timer_period_s(self.params))
        self.gain_changes = live_gains.Handover()
        self.status.log_gains(self.checked.margin)
        self.parameter_services = live_gains.ParameterServices(self)

    def setup(self, params: dict[str, Any]) -> None:
        # The arm model: the URDF's, or the model_* values over it (read-only: fixed at start).
        self.dynamics = arm_model(params)
        self.joint_names = list(self.dynamics.joint_names)
        self.joint_count = len(self.joint_names)
        # The same model again, for designing and checking a change in the designer's process (adaptation writes
        # its armature into the loop's own, and MuJoCo's data is not shared between threads).
        self.designer = Designer(arm_model(params), self.joint_count)
        if model_overridden(params):
            self.get_logger().info(self.dynamics.describe())

    def more_specs(self, values: dict[str, Any]) -> tuple[cfg.ParamSpec, ...]:
        """A law of one's own: its declared parameters, law.NAME (a value given for one it does
        not declare is refused, as the launcher's check does)."""
        specs = law_params.law_specs(values["controller_type"])
        declared = {spec.name for spec in specs}
        overrides = getattr(self, "_parameter_overrides", {})  # --params-file and -p values
        for name in sorted(overrides):
            if law_parameters.is_law_key(name) and name not in declared:
                law_parameters.check_values({"controller_type": values["controller_type"], name: None}, self.get_name())
        return specs

    def check_params(self, params: dict[str, Any]) -> None:
        # The law designs here, before the change is accepted (an LQR that does not stabilise is refused, not
        # found when applying it): on the parameter services' thread, waiting for the designer's process.
        config = cfg.controller_config(params, self.joint_count)
        running = getattr(self, "controller", None)
        changed = running is not None and config.controller_type != running.config.controller_type
        if changed and (config.plugin_law or running.config.plugin_law):
            raise ConfigError(
                "controller_type: a law of one's own is chosen when the controller starts; restart it to change"
            )
        if config.plugin_law:  # per-joint lengths and the like, as the law will be given them
            law_parameters.values(registry.resolve(config.controller_type), config.law_parameters, self.joint_count)
        margin = self.designer.margin(config)
        self.checked = live_gains.GainChange(config, params, margin=margin)  # what the post-set callback hands over

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        # On the parameter services' thread: the loop takes the change over at its next tick (take_gain_change).
        checked = self.checked
        self.gain_changes.offer(live_gains.GainChange(checked.config, params, set(changed), checked.margin))

    def take_gain_change(self) -> None:
        """At the start of a tick: the newest accepted change, if any, takes over (bumpless: the PID keeps its I term
        in N·m). Its law was designed and checked when it was accepted; should the controller refuse it even so,
        the law in force stays, said once."""
        change = self.gain_changes.take()
        if change is None:
            return
        try:
            self.controller.set_config(change.config)
        except ConfigError as exc:
            self.get_logger().warning(
                f"the law in force stays: the change to {sorted(change.changed)} was refused ({exc})"
            )
            return
        if change.changed & GAIN_KEYS or any(law_parameters.is_law_key(name) for name in change.changed):
            self.status.log_gains(change.margin)
        if change.changed & {"control_rate_hz", "trigger", "watchdog_periods"} and self.timer is not None:
            self.set_timer_period(self.timer_period_s(change.params))

    def finish(self) -> None:
        self.parameter_services.stop()
        self.designer.stop()
        self.timing.leave_host_misses()

    def destroy_node(self) -> None:
        self.parameter_services.stop()  # its thread first: it answers for this node
        self.designer.stop()
        super().destroy_node()

    def set_timer_period(self, period_s: float) -> None:
        if period_s == self.timer_period:
            return
        if self.timer is not None:
            self.destroy_timer(self.timer)
        self.timer = self.create_timer(period_s, self.control_callback)
        self.timer_period = period_s

    @staticmethod
    def timer_period_s(params: dict[str, Any]) -> float:
        """The timer ticks the loop (``trigger: timer``), or with readings driving it watches for
        their absence, twice per watchdog window (while they are missing it ticks the loop)."""
        period_s = 1.0 / params["control_rate_hz"]
        if params["trigger"] == "measurement":
            return period_s * max(1.0, params["watchdog_periods"] / 2)
        return period_s

    def joint_state_callback(self, msg: JointState) -> None:
        checked = check_joint_state(msg.name, msg.position, msg.velocity, self.joint_names)
        if isinstance(checked, str):
            self.drop(spec.READING.topic, checked)
            self.check_configuration(list(msg.name))
            return
        stamp_s = stamp_to_s(msg.header.stamp)
        if self.pairing is not None:
            self.pairing.take_reading(stamp_s, *checked)
        else:
            now_s = clock_s(self)
            refused = self.controller.set_measurement(stamp_s, now_s, *checked)
            if refused:
                self.warn_throttled("joint_states_age", f"{spec.READING.topic} dropped: {refused}")
                return
            self.timing.note_reading(now_s)
            if self.params["trigger"] == "measurement":
                self.set_timer_period(self.timer_period_s(self.params))  # readings drive the loop again
                self.tick(now_s)

    def check_configuration(self, names: list[str]) -> None:
        """Readings naming other joints than this controller's URDF, none usable since start, for
        ``CONFIG_MISMATCH_S``: the graph is configured for different arms; end with both named."""
        if self.controller.has_measurement or not names or sorted(names) == sorted(self.joint_names):
            self.mismatch_since = None
            return
        now = time.monotonic()
        self.mismatch_since = self.mismatch_since or now
        if now - self.mismatch_since > CONFIG_MISMATCH_S:
            raise ConfigError(
                f"joint names disagree: {spec.READING.topic} (the simulator's URDF) has {names}, "
                f"pid_controller's URDF ({self.params['urdf_path'] or 'the reference arm'}) has "
                f"{self.joint_names}"
            )

    def trajectory_callback(self, msg: Float64MultiArray) -> None:
        checked = check_trajectory(msg.data, self.joint_count)
        if isinstance(checked, str):
            return self.drop(spec.REFERENCE.topic, checked)
        position, velocity, acceleration, sample_time_s = checked
        self.reference_samples += 1
        # Received at the tick in force (lockstep: the sim's latest clock, so a sample sent a tick early waits for it).
        received_s = max(self.pairing.clock_s, 0.0) if self.pairing is not None else clock_s(self)
        self.controller.set_reference(received_s, position, velocity, acceleration, sample_time_s)
        if self.pairing is not None:
            self.pairing.try_tick()

    def control_callback(self) -> None:
        now_s = clock_s(self)
        period_s = self.controller.config.control_period_s
        if self.params["trigger"] == "measurement":
            covering = self.timer_period == period_s  # readings are missing: this timer ticks the loop
            if now_s - self.last_tick_s < (0.5 if covering else 1.5) * period_s:
                return  # readings are driving the loop; this timer only covers for their absence
            self.set_timer_period(period_s)
        self.tick(now_s)

    def brakes_callback(self, msg: Float64MultiArray) -> None:
        values = np.asarray(msg.data, dtype=float)
        if values.size == self.joint_count and np.all(np.isfinite(values)):
            engaged = bool(np.any(values > 0.5))
            if self.lockstep and engaged and brake_reasons(msg) == {"start"}:
                return
            self.controller.brakes(engaged)

    def tick(self, now_s: float) -> None:
        self.take_gain_change()
        out = self.controller.update(now_s)
        self.last_tick_s = now_s
        if self.first_tick_s is None:
            self.first_tick_s = now_s
        if out.status is Status.NO_MEASUREMENT:
            self.waits.waiting(
                "readings", f"the first valid {spec.READING.topic} reading (sensor_node's): not commanding"
            )
            return
        if out.status is not self.status.last_status:
            self.status.status_changed(out.status)
        if out.status is Status.LATE:
            self.timing.report_late()
        command = None
        if out.status.commanding:
            self.command_msg.data = out.command.tolist()
            stamp_command(self.command_msg, now_s)
            self.command_pub.publish(self.command_msg)
            command = tuple(self.command_msg.data)
        self.timing.note_tick(now_s, command, watchdog=out.status is Status.WATCHDOG)
        self.status.say_saturation(out)
        self.status.say_adaptation(now_s)
        self.status.publish_state(out)
        if self.log_schedule.due(now_s, self.params["log_period_s"]):
            self.get_logger().info(log_line.line(out.reference, out.measured, out.error, out.command))
        if out.status is Status.LAW_STOPPED:
            self.status.end_after_law_stop()


# How long (wall) a tick waits for a reference sample before using the latest.
REFERENCE_WAIT_S = 0.3


class LockstepPairing:
    """In lockstep (``lockstep: true``, sim time) each reading is a tick at the sim's clock it
    pairs with, computed once the reference sample due by then has arrived (or, from a planner
    slower than the control rate, after ``REFERENCE_WAIT_S`` with the latest)."""

    def __init__(self, node: PidControllerNode) -> None:
        self.node = node
        self.controller = node.controller
        self.clock_s = -np.inf  # the sim's latest clock
        self.reading: tuple[float, tuple[np.ndarray, np.ndarray]] | None = None  # waiting for its clock
        self.tick_s: float | None = None  # a measured tick waiting for its reference
        self.waiting_since = 0.0  # monotonic s the tick began waiting
        self.reference_waits = 0  # ticks that went on without a due reference sample
        node.create_timer(0.1, self.reference_wait_check, clock=Clock(clock_type=ClockType.STEADY_TIME))
        node.create_subscription(ClockMsg, spec.CLOCK.topic, self.clock_callback, LATCHED_QOS)

    def clock_callback(self, msg: ClockMsg) -> None:
        self.clock_s = max(self.clock_s, stamp_to_s(msg.clock))
        self.pair()

    def take_reading(self, stamp_s: float, position: np.ndarray, velocity: np.ndarray) -> None:
        """One reading per sim tick; the tick's time is the clock it pairs with (a delayed sensor's
        stamp is older than the tick)."""
        self.reading = (stamp_s, (position, velocity))
        self.pair()

    def pair(self) -> None:
        """A tick is due once the sim's clock for it and its reading are both in, whichever came
        first (the sim publishes the next clock only after this tick's command: one to one)."""
        if self.reading is None or self.tick_s is not None or self.clock_s <= self.node.last_tick_s:
            return
        stamp_s, (position, velocity) = self.reading
        if stamp_s > self.clock_s + 1e-9:
            return  # the reading is for a tick whose clock has not arrived yet
        self.reading = None
        refused = self.controller.set_measurement(stamp_s, self.clock_s, position, velocity)
        if refused:
            self.node.warn_throttled("joint_states_age", f"{spec.READING.topic} dropped: {refused}")
        self.tick_s = self.clock_s
        self.waiting_since = time.monotonic()
        self.try_tick()

    def try_tick(self) -> None:
        """Tick if the measured tick's reference sample is in."""
        tick_s = self.tick_s
        if tick_s is None or not self.controller.reference_ready(tick_s):
            return
        self.tick_s = None
        self.node.tick(tick_s)
        self.pair()

    def reference_wait_check(self) -> None:
        """A planner slower than the control rate leaves ticks with no sample due;
        until its period is learned from two samples, do not wait forever."""
        if self.tick_s is None:
            return
        node = self.node
        if not self.controller.has_reference():
            # Nothing to fall back on before the first sample: wait (the launcher ends a stalled lockstep).
            node.waits.waiting("reference", f"lockstep: the first {spec.REFERENCE.topic} sample (trajectory_planner's)")
            return
        if time.monotonic() - self.waiting_since > REFERENCE_WAIT_S:
            said = (
                f"lockstep: no reference sample for t={self.tick_s:.3f} s "
                f"after {REFERENCE_WAIT_S:g} s; using the latest"
            )
            if node.reference_samples < 2:
                # The planner's period is learned from its first two samples; until then a planner slower than the
                # control rate leaves ticks without a sample due: said once.
                if self.reference_waits == 0:
                    node.get_logger().info(said + " until the planner's rate is known from its second sample")
            else:
                node.warn_throttled("reference_wait", said)
            self.reference_waits += 1
            tick_s, self.tick_s = self.tick_s, None
            node.tick(tick_s)


def main(args: list[str] | None = None) -> int:
    return run(PidControllerNode, args)
