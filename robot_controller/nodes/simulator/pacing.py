"""The simulator's wall clock: a pacing thread that sleeps to each absolute deadline of a
``publish_rate_hz`` grid (never a drifting timer), steps the physics due by then and publishes the state."""

from __future__ import annotations

import sys
import threading
import time

from robot_controller.nodes.simulator.paced import FreezeLog
from robot_controller.ros import scheduling
from robot_controller.ros.stack_node import StackNode

# Catch up at most this many physics steps in one call; beyond, the sim runs slower than real time.
MAX_CATCH_UP_STEPS = 100


class Pacing:
    """The simulator's pacing thread and the physics it steps on the monotonic clock."""

    def __init__(self, node: StackNode) -> None:
        self.node = node
        # Physics time 0 on the monotonic clock (pacing; None before the first command) and the ROS clock.
        self.anchor_mono_ns: int | None = None
        self.anchor_ros_ns = 0
        self.behind_warned = False
        self.freezes = FreezeLog()  # wake-ups later than a whole period: the host's (or this process's) freezes
        self.stopping = threading.Event()
        self.thread: threading.Thread | None = None
        self.period_ns = round(1e9 / node.params["publish_rate_hz"])

    @property
    def running(self) -> bool:
        """The physics runs (it has a time 0)."""
        return self.anchor_mono_ns is not None

    def start(self) -> None:
        if not self.node.params["wait_for_first_command"]:
            self.begin()
        rt_priority = scheduling.realtime_thread_requested()
        if rt_priority is not None:
            scheduling.install_rt_budget()
        # A short GIL switch interval: the pacing thread must not wait long for a callback on the executor thread.
        sys.setswitchinterval(0.0005)
        self.thread = threading.Thread(target=self.pace, args=(rt_priority,), name="pacing", daemon=True)
        self.thread.start()

    def begin(self) -> None:
        """Physics time 0 is now."""
        self.anchor_mono_ns = time.monotonic_ns()
        self.anchor_ros_ns = self.node.get_clock().now().nanoseconds

    def pace(self, rt_priority: int | None) -> None:
        """The pacing thread: sleep to each absolute deadline, step, publish."""
        node = self.node
        if rt_priority is not None:
            node.get_logger().info(scheduling.make_current_thread_realtime(rt_priority))
        period_ns = self.period_ns
        deadline_ns = time.monotonic_ns() + period_ns
        last_wakeup_ns = time.monotonic_ns()
        while not self.stopping.is_set():
            remaining_ns = deadline_ns - time.monotonic_ns()
            if remaining_ns > 0:
                time.sleep(remaining_ns * 1e-9)
            with node.lock:
                now_ns = time.monotonic_ns()
                gap_ns = now_ns - last_wakeup_ns
                last_wakeup_ns = now_ns
                if self.running:
                    node.brakes.excuse_own_gap(gap_ns, period_ns)
                    node.brakes.check_drive_timeout(now_ns)
                    # Step to the deadline (not to now): the state is that of the grid point.
                    self.advance(max(deadline_ns, self.anchor_mono_ns))
                    stamp_ns = self.anchor_ros_ns + node.steps_done * node.physics_dt_ns
                else:
                    stamp_ns = node.get_clock().now().nanoseconds  # brakes on: the arm holds still
                if node.world is not None:
                    node.world.save(node.plant.state()[0])
                if node.state_pub.open:
                    node.publish_state(stamp_ns)
                node.brakes.report_periodically(now_ns)
                anchor = self.anchor_mono_ns
            # Next deadline on the grid of physics time 0 (or the last one while braked), skipping those missed.
            base = anchor if anchor is not None else deadline_ns
            if now_ns - deadline_ns >= period_ns:
                self.freezes.note(now_ns - deadline_ns)
            if rt_priority is not None and scheduling.demoted.is_set():
                rt_priority = None
                node.get_logger().warning(
                    "pacing thread used its real-time CPU budget without sleeping: back to normal scheduling"
                )
            deadline_ns = base + ((max(deadline_ns, now_ns) - base) // period_ns + 1) * period_ns

    def advance(self, until_mono_ns: int) -> None:
        """Step the physics that the clock says is due by ``until_mono_ns`` (lock held)."""
        node = self.node
        due = (until_mono_ns - self.anchor_mono_ns) // node.physics_dt_ns - node.steps_done
        if due <= 0:
            return
        if due > MAX_CATCH_UP_STEPS:
            if not self.behind_warned:
                node.get_logger().warning(f"physics {due} steps behind the clock: slowing below real time")
                self.behind_warned = True
            shift_ns = (due - MAX_CATCH_UP_STEPS) * node.physics_dt_ns
            self.anchor_mono_ns += shift_ns
            self.anchor_ros_ns += shift_ns
            due = MAX_CATCH_UP_STEPS
        node.step(int(due))

    def stop(self, counts_dir: str) -> None:
        """End the thread; say how often the host froze the loop, which on the wall clock counts against it."""
        if self.stopping.is_set():
            return
        self.stopping.set()
        if self.thread is not None and self.thread.is_alive():
            self.thread.join(timeout=1.0)
        meaning = "on the wall clock the late commands and brakes then were the host's"
        self.freezes.say_and_leave(self.node, counts_dir, meaning)
