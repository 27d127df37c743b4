"""The simulator's wall clock: the loop's hardware clock.

A pacing thread sleeps until each absolute deadline of a ``publish_rate_hz``
grid (never a drifting timer), steps the physics due by then and publishes
the state, so the sensor, and through its readings the controller, tick on a
steady grid. A new effort, taken on the executor thread, first steps the
physics up to its arrival on the old torque: it acts from the physics step it
arrived in.
"""

from __future__ import annotations

import sys
import threading
import time

from robot_controller.ros import scheduling

# Catch up at most this many physics steps in one callback; beyond, the sim
# runs slower than real time rather than jumping.
MAX_CATCH_UP_STEPS = 100


class SimulatorPacing:
    """The pacing thread of the :class:`~robot_controller.nodes.simulator.node.Simulator`
    and the physics it steps on the monotonic clock."""

    def init_pacing(self) -> None:
        """Set up the clock's state; :meth:`start_pacing` starts the thread (wall clock only)."""
        # Wall clock: physics time 0 on the monotonic clock (pacing) and on the
        # ROS clock (stamps); None while the brakes hold, before the first command.
        self.anchor_mono_ns: int | None = None
        self.anchor_ros_ns = 0
        self.lock = threading.Lock()  # the plant and effort: pacing thread vs effort callback
        self.behind_warned = False
        self.late_wakeups = 0
        self.stop_pacing = threading.Event()
        self.pacer: threading.Thread | None = None

    def start_pacing(self) -> None:
        p = self.params
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
                self.excuse_own_gap(gap_ns, period_ns)
                if self.anchor_mono_ns is None:
                    stamp_ns = self.get_clock().now().nanoseconds  # brakes on: the arm holds still
                else:
                    self.check_drive_timeout(now_ns)
                    # Step to the deadline (not to now): the state is that of the grid point.
                    self.advance(max(deadline_ns, self.anchor_mono_ns))
                    stamp_ns = self.anchor_ros_ns + self.steps_done * self.physics_dt_ns
                if self.world is not None:
                    self.world.save(self.plant.state()[0])
                if self.state_pub.open:
                    self.publish_state(stamp_ns)
                self.report_brakes_periodically(now_ns)
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

    def stop_pacing_thread(self) -> None:
        self.stop_pacing.set()
        if self.pacer is not None and self.pacer.is_alive():
            self.pacer.join(timeout=1.0)
            if self.late_wakeups:
                self.get_logger().info(f"pacing: {self.late_wakeups} wake-up(s) later than a whole period")
