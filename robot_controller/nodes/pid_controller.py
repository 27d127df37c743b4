"""pid_controller: the control law at ``control_rate_hz``.

Reads ``/joint_states`` (noisy) and ``/trajectory``, publishes one torque
per joint on ``/joint_commands``, every term on ``/controller/state`` and its
own loop health (period jitter, missed cycles, sensor-stamp-to-command
latency) on ``/diagnostics``. The maths is ``core.controller.JointController``;
this node only converts messages and parameters. The name stays
``pid_controller`` for the tutorial's sake whatever law ``controller_type``
selects.

Wall clock: a timer ticks at the control rate (``trigger: timer``), or each
new reading does (``trigger: measurement``, with the timer left to run the
watchdog when readings stop). Lockstep: each measurement is a tick, computed
once the reference sample due by then has arrived.

Longer than our ~250-line guideline: one node, one file (the ros2/examples
habit), with its two triggers, the lockstep pairing of readings with ticks
and its loop-health report; every decision about torque is in the core.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64MultiArray, MultiArrayDimension

from robot_controller import parameters as cfg
from robot_controller.core import metrics, state_layout
from robot_controller.core.controller import ControlOutput, JointController, Status, law_config
from robot_controller.core.errors import ConfigError
from robot_controller.core.laws import parameters as law_parameters
from robot_controller.core.laws import registry
from robot_controller.core.validation import check_joint_state, check_trajectory
from robot_controller.parameters import law_params
from robot_controller.parameters.builders import arm_model, model_overridden
from robot_controller.ros.process import LAW_FAULT_FILE, LAW_STOPPED_EXIT_CODE, request_exit, run
from robot_controller.ros.publishing import COUNTS_DIR_ENV, GatedPublisher
from robot_controller.ros.qos import ESTOP_QOS, LATCHED_QOS, LATEST_QOS, loop_qos
from robot_controller.ros.stack_node import StackNode
from robot_controller.ros.stamps import stamp_to_s

# While the loop is late, its one line comes at most this often (s).
LATE_LINE_PERIOD_S = 2.0
# Commands remembered with their tick time, to pair with the drive's receipts (a second's worth and more).
ISSUED_KEPT = 400
# The receipts come once a second, each message a second's rows: keep a few, never a backlog.
COMMAND_RECEIPTS_QOS = 5
# Readings naming other joints for this long, none usable yet: a configuration mismatch.
CONFIG_MISMATCH_S = 2.0
# Lockstep: how long (wall) a tick waits for a reference sample before using the latest.
REFERENCE_WAIT_S = 0.3
# Wall clock: after a failed law's stop, state is still published this long (the brakes engaging
# are recorded), then the node ends. In lockstep it ends at once: without commands sim time stops.
LAW_STOPPED_LINGER_S = 0.5


class PidControllerNode(StackNode):
    def __init__(self) -> None:
        super().__init__("pid_controller")
        # A law of one's own is held to its law_budget_s in wall time, in lockstep too. On the
        # wall clock the loop's delay is watched against the gains' delay margin (core.latency).
        self.controller = JointController(
            cfg.controller_config(self.params, self.joint_count),
            self.joint_count,
            self.dynamics,
            law_clock=time.perf_counter,
            latency_guard=not self.params["lockstep"],
        )
        plugin = self.controller.plugin
        # The law's extra terms on /controller/state, after the standard blocks (state_layout).
        self.extra_terms = tuple(
            name
            for name in (plugin.extra_terms if plugin is not None else ())
            if name not in state_layout.FIELDS and name not in state_layout.HEADER
        )
        self.law_stopped_since: float | None = None  # monotonic time LAW_STOPPED was first reached
        self.lockstep = self.params["lockstep"]
        self.command_pub = GatedPublisher(self, Float64MultiArray, "/joint_commands")
        self.state_pub = GatedPublisher(self, Float64MultiArray, "/controller/state", consumer=False)
        self.diagnostics_pub = GatedPublisher(self, DiagnosticArray, "/diagnostics", consumer=False)
        self.create_subscription(JointState, "/joint_states", self.joint_state_callback, loop_qos(self.lockstep))
        self.watch_single_publisher("/joint_states", "sensor_node")
        self.create_subscription(Float64MultiArray, "/trajectory", self.trajectory_callback, loop_qos(self.lockstep))
        self.watch_single_publisher("/trajectory", "trajectory_planner")
        self.create_subscription(Bool, "/estop", self.estop_callback, ESTOP_QOS)
        if not self.lockstep:
            # The drive's status word: its brakes (a real controller reads its drives' state
            # too). Not in lockstep, where its arrival against the ticks would be a race.
            self.create_subscription(Float64MultiArray, "/sim/brakes", self.brakes_callback, LATEST_QOS)
            # When each command reached the drive: the command path's delay, for the latency guard.
            self.create_subscription(
                Float64MultiArray, "/motor/command_receipts", self.receipts_callback, COMMAND_RECEIPTS_QOS
            )
        self.issued: deque[tuple[float, tuple[float, ...]]] = deque(maxlen=ISSUED_KEPT)  # (tick s, command)
        self.last_status: Status | None = None
        self.mismatch_since: float | None = None
        self.timer = None
        self.timer_period = 0.0
        if not self.lockstep:
            self.set_timer_period(self.timer_period_s(self.params))
        self.create_timer(self.params["diagnostics_period_s"], self.diagnostics_callback)
        self.pending_tick_s: float | None = None  # lockstep: measurement waiting for its reference
        self.pending_since = 0.0  # wall time (monotonic) the pending tick began waiting
        self.pending_reading: tuple[float, tuple[np.ndarray, np.ndarray]] | None = None  # lockstep
        self.sim_clock_s = -np.inf  # lockstep: the latest /clock
        if self.lockstep:
            self.create_timer(0.1, self.reference_wait_check, clock=Clock(clock_type=ClockType.STEADY_TIME))
            self.create_subscription(ClockMsg, "/clock", self.clock_callback, LATCHED_QOS)
        self.last_tick_s = -np.inf
        self.first_tick_s: float | None = None
        self.window_ticks: list[float] = []
        self.window_latency: list[float] = []
        self.command_msg = Float64MultiArray()
        self.state_msg = Float64MultiArray()
        self.state_msg.layout.dim = [
            MultiArrayDimension(label=name, size=1, stride=1) for name in state_layout.HEADER
        ] + [
            MultiArrayDimension(label=name, size=self.joint_count, stride=self.joint_count)
            for name in (*state_layout.FIELDS, *self.extra_terms)
        ]
        self.next_log_s = -np.inf
        self.next_late_line = -np.inf  # monotonic s: the latency stop's line, rate-limited
        self.log_gains()

    def log_gains(self) -> None:
        """The law and gains in force (LQR's are designed, not the kp/ki/kd parameters)
        and how much unaccounted delay they survive: in the log and as ``law_in_force``."""
        margin = self.controller.delay_margin_periods()
        rate_hz = self.params["control_rate_hz"]
        in_force = self.controller.law_in_force()
        if margin is not None:  # None: a law of one's own, whose feedback is not known here
            in_force += (
                f"; delay margin {margin} control periods ({margin * 1e3 / rate_hz:g} ms) beyond what the stamps show"
            )
        self.report("law_in_force", in_force, "the control law and its gains in force, as designed")
        self.get_logger().info(
            f"{in_force}; at {rate_hz:g} Hz on {self.joint_names}" + (", lockstep" if self.lockstep else "")
        )

    def setup(self, params: dict[str, Any]) -> None:
        # The arm model: the URDF's, or the model_* values over it (read-only: fixed at start).
        self.dynamics = arm_model(params)
        self.joint_names = list(self.dynamics.joint_names)
        self.joint_count = len(self.joint_names)
        if model_overridden(params):
            self.get_logger().info(self.dynamics.describe())

    def more_specs(self, values: dict[str, Any]) -> tuple[cfg.ParamSpec, ...]:
        """A law of one's own: its declared parameters, law.NAME (a value given for one it does
        not declare is refused, as the launcher's check does)."""
        specs = law_params.law_specs(values["controller_type"])
        declared = {spec.name for spec in specs}
        overrides = getattr(self, "_parameter_overrides", {})  # --params-file and -p values
        for name in sorted(overrides):
            if law_params.is_law_key(name) and name not in declared:
                law_params.check_values({"controller_type": values["controller_type"], name: None}, self.get_name())
        return specs

    def check_params(self, params: dict[str, Any]) -> None:
        # The law designs here, before the change is accepted (an LQR that does not
        # stabilise is refused, not found when applying it).
        config = cfg.controller_config(params, self.joint_count)
        law_config(config, self.dynamics, self.joint_count)
        running = getattr(self, "controller", None)
        changed = running is not None and config.controller_type != running.config.controller_type
        if changed and (config.plugin_law or running.config.plugin_law):
            raise ConfigError(
                "controller_type: a law of one's own is chosen when the controller starts; restart it to change"
            )
        if config.plugin_law:  # per-joint lengths and the like, as the law will be given them
            law_parameters.values(registry.resolve(config.controller_type), config.law_parameters, self.joint_count)

    def apply_params(self, params: dict[str, Any], changed: set[str]) -> None:
        self.controller.set_config(cfg.controller_config(params, self.joint_count))
        if changed & {"controller_type", "lqr_q", "lqr_r", "kp", "ki", "kd", "control_rate_hz"} or any(
            law_params.is_law_key(name) for name in changed
        ):
            self.log_gains()
        if changed & {"control_rate_hz", "trigger", "watchdog_periods"} and self.timer is not None:
            self.set_timer_period(self.timer_period_s(params))

    def set_timer_period(self, period_s: float) -> None:
        if period_s == self.timer_period:
            return
        if self.timer is not None:
            self.destroy_timer(self.timer)
        self.timer = self.create_timer(period_s, self.control_callback)
        self.timer_period = period_s

    @staticmethod
    def timer_period_s(params: dict[str, Any]) -> float:
        """The timer ticks the loop (``trigger: timer``), or with readings driving
        it only watches for their absence: twice per watchdog window is enough,
        and a quarter of the callbacks of a 100 Hz timer. (While readings are
        missing it ticks at the control rate: the controlled stop runs on it.)"""
        period_s = 1.0 / params["control_rate_hz"]
        if params["trigger"] == "measurement":
            return period_s * max(1.0, params["watchdog_periods"] / 2)
        return period_s

    # --- inputs -------------------------------------------------------------------

    def joint_state_callback(self, msg: JointState) -> None:
        checked = check_joint_state(msg.name, msg.position, msg.velocity, self.joint_names)
        if isinstance(checked, str):
            self.warn_throttled("joint_states", f"/joint_states dropped: {checked}")
            self.check_configuration(list(msg.name))
            return
        stamp_s = stamp_to_s(msg.header.stamp)
        if self.lockstep:
            # One reading per sim tick; the tick's time is the /clock it pairs with
            # (a delayed sensor's stamp is older than the tick).
            self.pending_reading = (stamp_s, checked)
            self.pair_lockstep_reading()
        else:
            now_s = self.now_s()
            refused = self.controller.set_measurement(stamp_s, now_s, *checked)
            if refused:
                self.warn_throttled("joint_states_age", f"/joint_states dropped: {refused}")
                return
            if self.params["trigger"] == "measurement":
                self.set_timer_period(self.timer_period_s(self.params))  # readings drive the loop again
                self.tick(now_s)

    def check_configuration(self, names: list[str]) -> None:
        """Readings that name other joints than this controller's URDF, and never a
        usable one since start: the graph is configured for different arms. End
        the run with both sides named (a hostile message later cannot do this:
        it only counts before the first valid reading)."""
        if self.controller.has_measurement or not names or sorted(names) == sorted(self.joint_names):
            self.mismatch_since = None
            return
        now = time.monotonic()
        self.mismatch_since = self.mismatch_since or now
        if now - self.mismatch_since > CONFIG_MISMATCH_S:
            raise ConfigError(
                f"joint names disagree: /joint_states (the simulator's URDF) has {names}, "
                f"pid_controller's URDF ({self.params['urdf_path'] or 'the reference arm'}) has "
                f"{self.joint_names}"
            )

    def trajectory_callback(self, msg: Float64MultiArray) -> None:
        checked = check_trajectory(msg.data, self.joint_count)
        if isinstance(checked, str):
            self.warn_throttled("trajectory", f"/trajectory dropped: {checked}")
            return
        position, velocity, acceleration, sample_time_s = checked
        self.controller.set_reference(self.now_s(), position, velocity, acceleration, sample_time_s)
        if self.lockstep:
            self.try_lockstep_tick()

    # --- ticks ----------------------------------------------------------------------

    def clock_callback(self, msg: ClockMsg) -> None:
        self.sim_clock_s = max(self.sim_clock_s, stamp_to_s(msg.clock))
        self.pair_lockstep_reading()

    def pair_lockstep_reading(self) -> None:
        """Lockstep: a tick is due once the sim's /clock for it and its reading are
        both in, whichever came first (the sim publishes the next /clock only
        after this tick's command, so they pair one to one)."""
        if self.pending_reading is None or self.pending_tick_s is not None or self.sim_clock_s <= self.last_tick_s:
            return
        stamp_s, (position, velocity) = self.pending_reading
        if stamp_s > self.sim_clock_s + 1e-9:
            return  # the reading is for a tick whose /clock has not arrived yet
        self.pending_reading = None
        refused = self.controller.set_measurement(stamp_s, self.sim_clock_s, position, velocity)
        if refused:
            self.warn_throttled("joint_states_age", f"/joint_states dropped: {refused}")
        self.pending_tick_s = self.sim_clock_s
        self.pending_since = time.monotonic()
        self.try_lockstep_tick()

    def try_lockstep_tick(self) -> None:
        tick_s = self.pending_tick_s
        if tick_s is None or not self.controller.reference_ready(tick_s):
            return
        self.pending_tick_s = None
        self.tick(tick_s)
        self.pair_lockstep_reading()

    def reference_wait_check(self) -> None:
        """A planner slower than the control rate leaves ticks with no sample due;
        until its period is learned from two samples, do not wait forever."""
        if self.pending_tick_s is None:
            return
        if not self.controller.has_reference():
            # Before the planner's first sample, nothing to fall back on: wait (the
            # launcher ends a run whose lockstep stalls).
            self.warn_throttled("first_reference", "lockstep: waiting for the first /trajectory sample")
            return
        if time.monotonic() - self.pending_since > REFERENCE_WAIT_S:
            self.warn_throttled(
                "reference_wait",
                f"lockstep: no reference sample for t={self.pending_tick_s:.3f} s "
                f"after {REFERENCE_WAIT_S:g} s; using the latest",
            )
            tick_s, self.pending_tick_s = self.pending_tick_s, None
            self.tick(tick_s)

    def control_callback(self) -> None:
        now_s = self.now_s()
        period_s = self.controller.config.control_period_s
        if self.params["trigger"] == "measurement":
            covering = self.timer_period == period_s  # readings are missing: this timer ticks the loop
            if now_s - self.last_tick_s < (0.5 if covering else 1.5) * period_s:
                return  # readings are driving the loop; this timer only covers for their absence
            self.set_timer_period(period_s)
        self.tick(now_s)

    def receipts_callback(self, msg: Float64MultiArray) -> None:
        """The drive's receipts, rows ``[receipt_time_s, command…]``: each paired with the latest
        tick that issued the same command before it, their difference is the command path's delay."""
        row = 1 + self.joint_count
        data = list(msg.data)
        if not data or len(data) % row:
            return
        ticks: dict[tuple[float, ...], list[float]] = {}
        for tick_s, command in self.issued:
            ticks.setdefault(command, []).append(tick_s)
        for start in range(0, len(data), row):
            receipt_s, command = data[start], tuple(data[start + 1 : start + row])
            earlier = [t for t in ticks.get(command, ()) if t <= receipt_s]
            if earlier:
                self.controller.command_delay(receipt_s, receipt_s - earlier[-1])

    def brakes_callback(self, msg: Float64MultiArray) -> None:
        values = np.asarray(msg.data, dtype=float)
        if values.size == self.joint_count and np.all(np.isfinite(values)):
            self.controller.brakes(bool(np.any(values > 0.5)))

    def estop_callback(self, msg: Bool) -> None:
        self.controller.halt(bool(msg.data))

    def tick(self, now_s: float) -> None:
        out = self.controller.update(now_s)
        self.last_tick_s = now_s
        if self.first_tick_s is None:
            self.first_tick_s = now_s
        if out.status is Status.NO_MEASUREMENT:
            self.warn_throttled("no_measurement", "no valid /joint_states yet: not commanding")
            return
        if out.status is not self.last_status:
            self.report_status(out.status)
        if out.status is Status.LATE:
            self.report_late()
        if out.status.commanding:
            self.command_msg.data = out.command.tolist()
            self.command_pub.publish(self.command_msg)
            if not self.lockstep:
                self.issued.append((now_s, tuple(self.command_msg.data)))
        self.window_ticks.append(now_s)
        if not self.lockstep:  # in lockstep a tick takes no sim time
            self.window_latency.append(self.now_s() - self.controller.measurement_stamp_s)
        self.publish_state(out)
        if now_s >= self.next_log_s:
            self.next_log_s = now_s + self.params["log_period_s"]
            self.get_logger().info(
                f"target={_fmt(out.reference)}, actual={_fmt(out.measured)}, error={_fmt(out.error)}, "
                f"torque={_fmt(out.command)}"
            )
        if out.status is Status.LAW_STOPPED:
            self.end_after_law_stop()

    def report_status(self, status: Status) -> None:
        """One log line when the loop's state changes (faults, stops, recovery)."""
        config = self.controller.config
        before, self.last_status = self.last_status, status
        lines = {
            Status.WATCHDOG: (
                "warning",
                f"no valid /joint_states for over {config.watchdog_periods} periods: "
                "controlled stop on the arm model's estimate (category 2)",
            ),
            Status.SENSOR_LOST: (
                "warning",
                f"no valid /joint_states for {config.sensor_timeout_s:g} s: no more "
                "commands, torque off, the brake holds (category 1)",
            ),
            Status.REFERENCE_LOST: ("warning", "no /trajectory sample for too long: controlled stop, holding"),
            Status.STOPPED: ("warning", "e-stop: not commanding until it is released"),
            Status.REACQUIRING: (
                "info",
                "fault cleared: re-acquiring from the measurement, blending back onto " "the trajectory",
            ),
        }
        if status is Status.LAW_FAULT and before is not Status.LAW_FAULT and self.controller.law_fault is not None:
            self.report_law_fault()
            return
        if status is Status.LAW_STOPPED:
            self.get_logger().warning(
                "the arm is at rest after the control law's failure: no more commands, torque off, "
                f"the brakes hold (category 1); pid_controller ends (exit code {LAW_STOPPED_EXIT_CODE})"
            )
            return
        if status in (Status.REACQUIRING, Status.OK) and before in (None, Status.HOLDING):
            self.get_logger().info(
                "first reading and reference: leading the arm from where it is onto the " "trajectory"
            )
            return
        if status in lines:
            # One call site per severity: rclpy's logger refuses two at one site.
            level, text = lines[status]
            if level == "warning":
                self.get_logger().warning(text)
            else:
                self.get_logger().info(text)
        elif status is Status.OK and before not in (None, Status.HOLDING, Status.OK):
            self.get_logger().info("tracking the trajectory again")

    def report_late(self) -> None:
        """One line (at most every LATE_LINE_PERIOD_S) while the loop is later than its gains survive."""
        now = time.monotonic()
        if now < self.next_late_line:
            return
        self.next_late_line = now + LATE_LINE_PERIOD_S
        late = self.controller.latency
        margin = self.controller.delay_margin_periods()
        self.get_logger().warning(
            f"readings/commands {late.delay_s * 1e3:.0f} ms late beyond what the stamps account for; the gains "
            f"survive {late.tolerated_s * 1e3:.0f} ms (delay margin {margin} periods): controlled stop, holding "
            f"until it is back within {late.tolerated_s * 0.5e3:.0f} ms for 1 s (category 2)"
        )

    def report_law_fault(self) -> None:
        """Once, when the law first fails: one error line (what it did, what happens next), the
        law's traceback after it, and the line in the run's folder for the launcher to name."""
        fault = self.controller.law_fault
        if not self.lockstep:  # the wall clock's tick times are the system's: count from the first tick
            fault = dataclasses.replace(fault, time_s=fault.time_s - self.first_tick_s)
        line = (
            f"{fault.line()}: controlled stop on the built-in {self.controller.config.stop_law}, "
            "then torque off and the brakes"
        )
        self.get_logger().error(line)
        if fault.traceback:
            self.get_logger().info("the control law's traceback:\n" + fault.traceback.rstrip())
        counts_dir = os.environ.get(COUNTS_DIR_ENV, "")
        if counts_dir:
            try:
                (Path(counts_dir) / LAW_FAULT_FILE).write_text(line + "\n")
            except OSError:
                pass  # the launcher then only knows the node's exit code

    def end_after_law_stop(self) -> None:
        """The failed law's stop is over and the brakes hold: end the node (its exit code says
        why), at once in lockstep, after LAW_STOPPED_LINGER_S of state on the wall clock."""
        now = time.monotonic()
        if self.law_stopped_since is None:
            self.law_stopped_since = now
        if self.lockstep or now - self.law_stopped_since >= LAW_STOPPED_LINGER_S:
            request_exit(LAW_STOPPED_EXIT_CODE)

    def publish_state(self, out: ControlOutput) -> None:
        terms = out.terms
        self.state_msg.data = state_layout.encode(
            out.time_s,
            out.status.value,
            self.controller.measurement_stamp_s,
            self.joint_count,
            {
                "reference": out.reference,
                "measured": out.measured,
                "error": out.error,
                "p": terms.p,
                "i": terms.i,
                "d": terms.d,
                "feedforward": terms.feedforward,
                "command": terms.command,
                "saturated": terms.saturated,
            },
            self.law_term_blocks(out),
        )
        self.state_pub.publish(self.state_msg)

    def law_term_blocks(self, out: ControlOutput) -> tuple[np.ndarray, ...]:
        """The law's extra terms in the layout's order; zeros on a tick the law did not run."""
        if not self.extra_terms:
            return ()
        reported = out.law_terms or {}
        zeros = np.zeros(self.joint_count)
        return tuple(reported.get(name, zeros) for name in self.extra_terms)

    # --- loop health ------------------------------------------------------------------

    def diagnostics_callback(self) -> None:
        ticks, latency = self.window_ticks, self.window_latency
        self.window_ticks, self.window_latency = ticks[-1:], []
        status = DiagnosticStatus(name="pid_controller: control loop", hardware_id="robot_controller")
        values: dict[str, float] = {"ticks": float(max(len(ticks) - 1, 0))}
        if len(ticks) >= 2:
            values.update(metrics.rate_metrics(np.asarray(ticks), self.controller.config.control_period_s))
        values.update(metrics.latency_metrics(np.asarray(latency)))
        if len(ticks) < 2:
            status.level, status.message = DiagnosticStatus.WARN, "not commanding"
        elif values.get("missed_cycles", 0) > 0:
            status.level, status.message = DiagnosticStatus.WARN, f"{int(values['missed_cycles'])} missed cycle(s)"
        else:
            status.level, status.message = DiagnosticStatus.OK, "running"
        status.values = [KeyValue(key=k, value=f"{v:.6g}") for k, v in values.items()]
        report = DiagnosticArray(status=[status])
        report.header.stamp = self.get_clock().now().to_msg()
        self.diagnostics_pub.publish(report)


def _fmt(values: Any) -> str:
    return ",".join(f"{v:.3f}" for v in values)


def main(args: list[str] | None = None) -> int:
    return run(PidControllerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
