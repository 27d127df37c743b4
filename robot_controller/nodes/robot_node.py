"""robot_node: the arm of a run on a robot (``run --hardware franka://HOST``), in place of the simulator, the motor,
the sensor and the controller. It forks the drive (``hardware.robot_drive``: the robot's connection and the
controller, stepped by the robot's clock, no ROS) before ROS starts, and is the drive's face to the graph
(``robot_drive``): the planner's samples (port ``reference``) and the e-stop (``estop``) to it; its ticks (``state``),
the robot's own state as the arm's (``true_state``) and as the readings (``reading``), every
``robot_link.TELEMETRY_EVERY``-th tick; the brakes (``brakes``: released while the robot is under torque control,
held after an e-stop or a fault) and the robot's timing (``diagnostics``).

Two processes, not a thread: a Python thread of the drive's interpreter holds it from the GIL for up to its
switch interval (5 ms) at a time; the robot stops after 20 late commands. They share memory
(``hardware.robot_link``) and the drive never waits on it."""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import sys
import time
from multiprocessing.connection import Connection
from typing import Any

from robot_controller import parameters as cfg
from robot_controller.blocks.controller_reports import Reports
from robot_controller.core.errors import ConfigError
from robot_controller.hardware.franka_arm import ROTOR_INERTIA_KGM2, FrankaArm, RobotFault, parse_hardware
from robot_controller.hardware.robot_drive import GUARD_TICKS, Drive, parent_watch, stopped_row, wait_for_go
from robot_controller.hardware.robot_link import END, RobotLink
from robot_controller.hardware.robot_loop import robot_loop
from robot_controller.ros import scheduling
from robot_controller.ros.process import ROBOT_FAULT_FILE
from robot_controller.ros.publishing import leave

NODE_NAME = "robot_drive"
#: the drive's exit code when the robot stopped itself (a reflex, a lost link)
ROBOT_FAULT_EXIT = 3
#: the drive's SCHED_FIFO priority: under the kernel's interrupt threads (50), over everything else of the stack
DRIVE_RT_PRIORITY = 40
#: s the drive waits for the graph (the recorder matched) before its first tick
GO_TIMEOUT_S = 60.0


def _drive_process(
    host: str, loop, link: RobotLink, reports: Reports, stop_deceleration: float, gains: Connection
) -> int:
    """The forked drive: connect, recover a reflex left from before (one line), wait for the graph, run."""
    import setproctitle

    setproctitle.setproctitle(f"robot_controller robot drive (franka://{host})")
    # The run's end reaches the drive from its ROS side, once the arm is brought to rest: the launcher's SIGINT to the
    # whole process group must not cut it short. SIGTERM asks the same.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, lambda *_: link.request(END))
    parent_alive = parent_watch()
    try:
        arm = FrankaArm(host)
        arm.recover_if_needed(lambda line: print(line, flush=True))
    except RobotFault as fault:
        return _failed(link, fault.describe())
    if not wait_for_go(link, parent_alive, GO_TIMEOUT_S):
        arm.close()
        return 0
    # Real-time, as libfranka asks of its control loop (its own default enforces it): SCHED_FIFO on the loop's CPU,
    # within a CPU budget per wake-up. At nice -10 a tool starting beside it (goto, estop: a second of CPU) held it
    # back for 20 periods, and the robot stopped.
    scheduling.install_rt_budget()
    print(_realtime_note(scheduling.make_current_thread_realtime(DRIVE_RT_PRIORITY)), flush=True)
    # Ticks on the graph's clock (ROS time, the system clock): the planner's samples and the recorder's stamps.
    offset_s = time.time() - time.monotonic()
    new_gains = lambda: gains.recv() if gains.poll() else None  # noqa: E731 (a non-blocking look, every tick)
    drive = Drive(loop, arm, link, reports, offset_s, stop_deceleration, parent_alive, new_gains)
    end = drive.run()
    if end.fault is not None:
        return _failed(link, f"{end.fault.describe()} at {end.at_s - drive.started_s:.2f} s")
    if end.why == "estop":
        link.say_phase("estopped")
        print("e-stop: the robot stopped under control, then by libfranka's stop (its brakes)", flush=True)
        drive.stand(stopped_row(reports, len(loop.joint_names)))
    elif end.why.startswith("guard:"):
        joint = end.why.split(":", 1)[1]
        line = (
            f"our guard braked {joint} for {GUARD_TICKS} ms at {end.at_s - drive.started_s:.2f} s: its reference asks "
            "more than the robot allows there (its speed, near a position limit); the motion was stopped under control"
        )
        link.say_phase("ended")
        arm.close()
        return _failed(link, line)
    elif end.why == "link":
        arm.close()
        line = (
            f"the robot took only {drive.success_rate_low:.2f} of our last 100 commands in time at "
            f"{end.at_s - drive.started_s:.2f} s: the motion was stopped under control (the link to it, or this host, "
            "cannot hold its 1 kHz)"
        )
        return _failed(link, line)
    elif end.why != "end":  # the controller stopped the motion itself (a law of one's own failed, …)
        arm.close()
        fault = loop.controller.law_fault
        return _failed(
            link, f"the control law failed: {fault.line()}" if fault else f"the controller stopped: {end.why}"
        )
    else:
        link.say_phase("ended")
    arm.close()
    return 0


def _realtime_note(note: str) -> str:
    return note.replace("pacing thread", "the drive")


def _failed(link: RobotLink, line: str) -> int:
    link.say_phase("fault")
    leave(ROBOT_FAULT_FILE, line)
    print(line, file=sys.stderr, flush=True)
    return ROBOT_FAULT_EXIT


class _Said:
    """The drive's lines (the controller's status changes, the law in force), printed: the launcher relays them under
    the process's name. A keyed warning once a key."""

    def __init__(self) -> None:
        self._warned: set[str] = set()

    def info(self, message: str) -> None:
        print(message, flush=True)

    def warn(self, key: str, message: str) -> None:
        if key not in self._warned:
            self._warned.add(key)
            print(f"WARNING: {message}", flush=True)

    def warning(self, message: str) -> None:
        print(f"WARNING: {message}", flush=True)

    error = warning


def _fork_drive(host: str, params: cfg.Params) -> tuple[int, RobotLink, Any, Reports, Connection]:
    """The drive forked (before any ROS in this process), with the link to it and the end gain changes go in at."""
    loop = robot_loop(params, ROTOR_INERTIA_KGM2)
    reports = Reports(_Said(), loop.controller, world_waits=False)
    state_size = sum(size for _, size in reports.state_blocks)
    link = RobotLink(len(loop.joint_names), state_size)
    stop_deceleration = float(params["pid_controller"]["stop_deceleration"])
    # Gain changes, rare and small: a pipe the drive looks into each tick without waiting.
    gains_out, gains_in = multiprocessing.Pipe(duplex=False)
    sys.stdout.flush()
    cpus = scheduling.loop_cpus()
    pid = os.fork()
    if cpus is not None:  # the drive on the loop's CPU, alone; the ROS side on the others (ros.scheduling)
        with contextlib.suppress(OSError):
            os.sched_setaffinity(0, cpus[0] if pid == 0 else cpus[1])
    if pid == 0:
        code = 1
        try:
            gains_in.close()
            code = _drive_process(host, loop, link, reports, stop_deceleration, gains_out)
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(code)
    gains_out.close()
    return pid, link, loop, reports, gains_in


def main(args: list[str] | None = None) -> int:
    """``robot_node franka://HOST --ros-args --params-file FILE`` (``args``: the program's name first, as rclpy's)."""
    argv = list(sys.argv if args is None else args)
    try:
        host = parse_hardware(argv[1] if len(argv) > 1 else "")
        params = cfg.read_params_file(argv[argv.index("--params-file") + 1])
    except (ValueError, ConfigError, IndexError) as exc:
        print(f"error: {exc}", file=sys.stderr, flush=True)
        return 2
    pid, link, loop, reports, gains = _fork_drive(host, params)
    from robot_controller.nodes.robot_bridge import serve  # rclpy: in this process only, after the fork

    send_gains = lambda config, margin: gains.send((config, margin))  # noqa: E731
    return serve([argv[0], *argv[2:]], pid, link, list(loop.joint_names), list(reports.state_blocks), send_gains)


if __name__ == "__main__":
    raise SystemExit(main())
