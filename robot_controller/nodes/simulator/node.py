"""simulator: the physics world (the Gazebo role). MuJoCo steps the arm
from the URDF at ``physics_rate_hz`` applying the latest ``/sim/effort``;
the true state goes out on ``/sim/joint_states``, stamped with its physics
time.

Wall clock: the simulator is the loop's hardware clock. A pacing thread
sleeps until each absolute deadline of a ``publish_rate_hz`` grid (never a
drifting timer), steps the physics due by then and publishes the state, so
the sensor, and through its readings the controller, tick on a steady grid.
A new effort, taken on the executor thread, first steps the physics up to
its arrival on the old torque: it acts from the physics step it arrived in.

Protections of the drive (docs/design.md §4), as real hardware has them: each
joint has a holding brake, engaged before the first effort, on e-stop
(``/estop``, ``std_msgs/Bool``, latched; or the ``/simulator/estop``
``std_srvs/SetBool`` service), when the motor asks (``/sim/brake``), and
when efforts stop arriving for ``drive_timeout_s``; a braked joint gets no
torque. The brakes' state goes out on ``/sim/brakes`` (one value per joint,
1 = engaged) whenever it changes and twice a second.

Disturbances (``/sim/disturbance``, ``std_msgs/Float64MultiArray``
``[torque_nm…, duration_s]``): an external torque on each joint, in the
physics beside the actuator's (not limited by the drive, not cut by the
brakes, which hold against it as against gravity; capped at
``MAX_DISTURBANCE_NM``), from its arrival (wall clock) or the next tick
(lockstep) for ``duration_s`` of physics time; a new one replaces it. The
torque acting goes out on ``/sim/disturbance_applied`` ``[torque_nm…, time_s]``
(``time_s`` = the true state's stamp) with every true state while it is on,
and once more, zero, when it ends.

Lockstep (``lockstep: true``, sim time): the sim owns time. It publishes
``/clock`` and the state for tick k, then waits; the effort for tick k
advances exactly one control period. No effort, no time: a run is
deterministic and as fast as the graph can go.

Longer than our ~250-line guideline: one node, one file (the ros2/examples
habit), and a drive's three modes (paced, lockstep, braked) share its state.
The physics is ``core.plant``; the kept arm state is ``world_state``.
"""

from __future__ import annotations

import os
import sys
import threading
import time

import numpy as np
from rclpy.clock import Clock, ClockType
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState
from std_msgs.msg import Bool, Float64MultiArray, MultiArrayDimension
from std_srvs.srv import SetBool

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.payload import Payload
from robot_controller.core.plant import MAX_DISTURBANCE_NM, MujocoPlant, check_disturbance, steps_per_period
from robot_controller.core.validation import check_effort
from robot_controller.nodes.world_state import WORLD_STATE_ENV, WorldState
from robot_controller.ros import scheduling
from robot_controller.ros.process import run
from robot_controller.ros.publishing import GatedPublisher
from robot_controller.ros.qos import CLOCK_QOS, ESTOP_QOS, LATCHED_QOS, LATEST_QOS
from robot_controller.ros.stack_node import StackNode

# Catch up at most this many physics steps in one callback; beyond, the sim
# runs slower than real time rather than jumping.
MAX_CATCH_UP_STEPS = 100
BRAKES_REPORT_PERIOD_NS = 500_000_000
# The simulator's own pause (frozen, starved) up to this long does not count
# against the drive's timeout; after a longer one it resumes braked (by then
# the controller has given up: sensor_timeout_s, 1 s by default).
MAX_EXCUSED_GAP_NS = 1_000_000_000


class Simulator(StackNode):
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
        # Wall clock: physics time 0 on the monotonic clock (pacing) and on the
        # ROS clock (stamps); None while the brakes hold, before the first command.
        self.anchor_mono_ns: int | None = None
        self.anchor_ros_ns = 0
        self.lock = threading.Lock()  # the plant and effort: pacing thread vs effort callback
        self.behind_warned = False
        self.lockstep = p["lockstep"]
        self.efforts_applied = 0
        self.ticks_published = 0
        self.late_wakeups = 0

        self.state_pub = GatedPublisher(self, JointState, "/sim/joint_states")
        # Only the newest effort matters to a drive (lockstep sends one at a time anyway).
        self.effort_sub = self.create_subscription(Float64MultiArray, "/sim/effort", self.effort_callback, LATEST_QOS)
        self.watch_single_publisher("/sim/effort", "motor_node")
        # Brakes: why each is on (any reason holds it), and who may ask.
        self.brake_reasons: set[str] = {"start"}
        self.plant.set_brakes(np.ones(self.joint_count, dtype=bool), p["brake_torque_nm"])
        self.last_effort_mono_ns = 0
        self.brakes_pub = GatedPublisher(self, Float64MultiArray, "/sim/brakes", consumer=False)
        self.brakes_msg = Float64MultiArray()
        self.brakes_msg.layout.dim = [
            MultiArrayDimension(label="engaged", size=self.joint_count, stride=self.joint_count)
        ]
        self.next_brakes_report_ns = 0
        self.create_subscription(Bool, "/sim/brake", self.brake_request_callback, LATCHED_QOS)
        self.brake_request_heard = False
        self.create_subscription(Bool, "/estop", self.estop_callback, ESTOP_QOS)
        self.create_service(SetBool, "/simulator/estop", self.estop_service)
        self.state_msg = JointState()
        self.state_msg.name = list(self.plant.joint_names)
        # External disturbances: taken like an effort, applied in the physics beside it.
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
        self.stop_pacing = threading.Event()
        self.pacer: threading.Thread | None = None
        if self.lockstep:
            self.steps_per_tick = steps_per_period(self.plant.physics_dt, 1.0 / p["control_rate_hz"])
            self.clock_pub = GatedPublisher(self, ClockMsg, "/clock", consumer=False, qos=CLOCK_QOS)
            self.clock_msg = ClockMsg()
            self.waiting_for_effort = False
            self.start_poll = self.create_timer(
                0.05, self.start_lockstep, clock=Clock(clock_type=ClockType.STEADY_TIME)
            )
        else:
            if not p["wait_for_first_command"]:
                self.release_brakes()
            self.publish_period_ns = round(1e9 / p["publish_rate_hz"])
            self.drive_timeout_ns = round(1e9 * p["drive_timeout_s"])
            rt_priority = scheduling.realtime_thread_requested()
            if rt_priority is not None:
                scheduling.install_rt_budget()
            # A short GIL switch interval: the pacing thread must not wait
            # long for a callback running on the executor thread.
            sys.setswitchinterval(0.0005)
            self.pacer = threading.Thread(target=self.pace, args=(rt_priority,), name="pacing", daemon=True)
            self.pacer.start()
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

    # --- effort in ------------------------------------------------------------

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

    # --- disturbance in -------------------------------------------------------

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

    # --- brakes -------------------------------------------------------------------

    def set_brake(self, reason: str, on: bool) -> None:
        """Add or remove one reason for the brakes (lock held); the brakes hold
        while any reason does, and a braked joint gets no torque."""
        before = bool(self.brake_reasons)
        if on:
            self.brake_reasons.add(reason)
        else:
            self.brake_reasons.discard(reason)
        engaged = bool(self.brake_reasons)
        if engaged != before:
            self.plant.set_brakes(np.full(self.joint_count, engaged), self.params["brake_torque_nm"])
            if engaged:
                self.effort = np.zeros(self.joint_count)
            self.report_brakes()

    def report_brakes(self) -> None:
        self.brakes_msg.data = [1.0 if self.brake_reasons else 0.0] * self.joint_count
        self.brakes_pub.publish(self.brakes_msg)

    def brake_request_callback(self, msg: Bool) -> None:
        with self.lock:
            self.brake_request_heard = True
            if bool(msg.data) != ("requested" in self.brake_reasons):
                self.get_logger().warning(
                    "brake requested by the motor: torque off, brakes on"
                    if msg.data
                    else "motor released its brake request"
                )
            self.set_brake("requested", bool(msg.data))

    def estop_callback(self, msg: Bool) -> None:
        self.set_estop(bool(msg.data))

    def estop_service(self, request: SetBool.Request, response: SetBool.Response) -> SetBool.Response:
        self.set_estop(bool(request.data))
        response.success = True
        response.message = "e-stop engaged: torque off, brakes on" if request.data else "e-stop released"
        return response

    def set_estop(self, on: bool) -> None:
        with self.lock:
            if on == ("estop" in self.brake_reasons):
                return
            if self.anchor_mono_ns is not None and not self.lockstep:
                self.advance(time.monotonic_ns())
            self.set_brake("estop", on)
        self.get_logger().warning(
            "E-STOP: torque off, brakes on (latched until released)"
            if on
            else "e-stop released: brakes release when efforts arrive"
        )
        if not on:
            with self.lock:
                # Released, the brakes wait for the drive's next effort.
                self.set_brake("drive_timeout", True)

    # --- wall clock -------------------------------------------------------------

    def release_brakes(self) -> None:
        """Physics time 0 is now."""
        self.anchor_mono_ns = time.monotonic_ns()
        self.anchor_ros_ns = self.get_clock().now().nanoseconds

    def pace(self, rt_priority: int | None) -> None:
        """The pacing thread: sleep to each absolute deadline, step, publish."""
        if rt_priority is not None:
            self.get_logger().info(scheduling.make_current_thread_realtime(rt_priority))
        period_ns = self.publish_period_ns
        deadline_ns = time.monotonic_ns() + period_ns
        last_wakeup_ns = time.monotonic_ns()
        while not self.stop_pacing.is_set():
            remaining_ns = deadline_ns - time.monotonic_ns()
            if remaining_ns > 0:
                time.sleep(remaining_ns * 1e-9)
            with self.lock:
                now_ns = time.monotonic_ns()
                gap_ns = now_ns - last_wakeup_ns
                last_wakeup_ns = now_ns
                if gap_ns > 2 * period_ns and self.anchor_mono_ns is not None:
                    if gap_ns <= MAX_EXCUSED_GAP_NS:
                        # This process was not running (frozen, starved) for a moment: that
                        # time does not count against the drive, whose efforts are waiting to be read.
                        self.last_effort_mono_ns += gap_ns - period_ns
                    elif "drive_timeout" not in self.brake_reasons:
                        # Longer, and the efforts waiting are as old: resume braked (the arm
                        # holds from here), until a fresh one arrives.
                        self.set_brake("drive_timeout", True)
                        self.warn_throttled(
                            "own_gap",
                            f"this simulator did not run for {gap_ns * 1e-9:.2f} s: " "resuming with the brakes on",
                        )
                if self.anchor_mono_ns is None:
                    stamp_ns = self.get_clock().now().nanoseconds  # brakes on: the arm holds still
                else:
                    if (
                        now_ns - self.last_effort_mono_ns > self.drive_timeout_ns
                        and "drive_timeout" not in self.brake_reasons
                    ):
                        self.advance(now_ns)
                        self.set_brake("drive_timeout", True)
                        self.warn_throttled(
                            "drive_timeout",
                            f"no effort for over {self.params['drive_timeout_s']:g} "
                            "s: torque off, brakes on (category 0)",
                        )
                    # Step to the deadline (not to now): the state is that of the grid point.
                    self.advance(max(deadline_ns, self.anchor_mono_ns))
                    stamp_ns = self.anchor_ros_ns + self.steps_done * self.physics_dt_ns
                if self.world is not None:
                    self.world.save(self.plant.state()[0])
                if self.state_pub.open:
                    self.publish_state(stamp_ns)
                if now_ns >= self.next_brakes_report_ns:
                    self.next_brakes_report_ns = now_ns + BRAKES_REPORT_PERIOD_NS
                    self.report_brakes()
                anchor = self.anchor_mono_ns
            # Next deadline on the grid of physics time 0 (or of the last one while
            # the brakes hold); a late wake-up skips the deadlines it missed.
            base = anchor if anchor is not None else deadline_ns
            missed = max(0, (now_ns - deadline_ns) // period_ns)
            if missed:
                self.late_wakeups += 1
            if rt_priority is not None and scheduling.demoted.is_set():
                rt_priority = None
                self.get_logger().warning(
                    "pacing thread used its real-time CPU budget without sleeping: " "back to normal scheduling"
                )
            deadline_ns = base + ((max(deadline_ns, now_ns) - base) // period_ns + 1) * period_ns

    def advance(self, until_mono_ns: int) -> None:
        """Step the physics that the clock says is due by ``until_mono_ns`` (lock held)."""
        due = (until_mono_ns - self.anchor_mono_ns) // self.physics_dt_ns - self.steps_done
        if due <= 0:
            return
        if due > MAX_CATCH_UP_STEPS:
            if not self.behind_warned:
                self.get_logger().warning(f"physics {due} steps behind the clock: slowing below real time")
                self.behind_warned = True
            shift_ns = (due - MAX_CATCH_UP_STEPS) * self.physics_dt_ns
            self.anchor_mono_ns += shift_ns
            self.anchor_ros_ns += shift_ns
            due = MAX_CATCH_UP_STEPS
        self.start_scheduled_disturbance()
        self.plant.step(self.effort, int(due))
        self.steps_done += int(due)
        self.note_disturbance_end()

    # --- lockstep ----------------------------------------------------------------

    def start_lockstep(self) -> None:
        """Publish tick 0 once the sensor (and recorder) listen and the motor talks (nothing is ever re-sent)."""
        # The motor matched (not only named in the graph: a motor of an earlier run can linger there).
        if not (self.state_pub.open and self.clock_pub.open and self.effort_sub.get_publisher_count()):
            return
        self.destroy_timer(self.start_poll)
        self.get_logger().info("lockstep: sensor and motor matched, starting at t = 0")
        self.publish_tick()

    def lockstep_effort(self, effort: np.ndarray) -> None:
        if not self.waiting_for_effort:
            self.warn_throttled("extra_effort", "lockstep: effort with no tick waiting for it, ignored")
            return
        self.waiting_for_effort = False
        self.set_brake("start", False)
        self.set_brake("drive_timeout", False)
        self.effort = np.zeros(self.joint_count) if self.brake_reasons else effort
        self.efforts_applied += 1
        self.start_scheduled_disturbance()
        self.plant.step(self.effort, self.steps_per_tick)
        self.steps_done += self.steps_per_tick
        self.note_disturbance_end()
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
        msg.effort = [0.0] * self.joint_count if self.brake_reasons else self.effort.tolist()
        self.state_pub.publish(msg)
        # The disturbance that acted in the last physics step: with every state while
        # there is one, then once zero.
        applied = self.plant.disturbance_torque
        nonzero = bool(applied.any())
        if nonzero or self.disturbance_reported:
            self.disturbance_msg.data = applied.tolist() + [stamp_ns * 1e-9]
            self.disturbance_pub.publish(self.disturbance_msg)
            self.disturbance_reported = nonzero

    def finish(self) -> None:
        self.stop_pacing.set()
        if self.pacer is not None and self.pacer.is_alive():
            self.pacer.join(timeout=1.0)
            if self.late_wakeups:
                self.get_logger().info(f"pacing: {self.late_wakeups} wake-up(s) later than a whole period")

    def destroy_node(self) -> None:
        self.finish()
        if self.lockstep:
            self.get_logger().info(
                f"lockstep: {self.ticks_published} ticks published, {self.efforts_applied} "
                f"efforts applied, t = {self.steps_done * self.plant.physics_dt:.3f} s"
            )
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return run(Simulator, args)


if __name__ == "__main__":
    raise SystemExit(main())
