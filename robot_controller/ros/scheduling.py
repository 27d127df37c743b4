"""Where and how urgently each process of the loop runs: by nice value, no process real-time (the
kernel freezes every SCHED_FIFO task once they use ``sched_rt_runtime_us``). With ``--realtime`` the
simulator's pacing thread alone runs SCHED_FIFO within an ``RLIMIT_RTTIME`` budget (docs/design.md §5)."""

from __future__ import annotations

import os
import resource
import signal
import threading
from dataclasses import dataclass

# nice values (−20 most urgent … 19): loop nodes, then the planner (it feeds samples ahead), observers last.
LOOP_NICE = -10
PLANNER_NICE = -5
OBSERVER_NICE = 10
LOOP_PROCESSES = frozenset({"simulator", "motor_node", "sensor_node", "pid_controller", "stack"})
NICE = {**dict.fromkeys(LOOP_PROCESSES, LOOP_NICE), "trajectory_planner": PLANNER_NICE, "recorder": OBSERVER_NICE}

# Sim time: a tick is a chain (simulator → sensor → controller → motor → simulator); planner and recorder yield to it,
# and so does a camera, whose frames render while their latency passes (its answer to each tick is a message alone).
SIM_TIME_NICE = {"trajectory_planner": 5, "recorder": 10, "camera_node": 5, "vision_node": 5}

#: SCHED_FIFO priority of the simulator's pacing thread under ``--realtime``.
PACING_RT_PRIORITY = 30
#: CPU time (µs) the FIFO thread may use without blocking before it is demoted: far over
#: a pacing period (the kernel counts in scheduler ticks), far below the kernel's throttle.
RT_BUDGET_US = 200_000
#: Environment variable the launcher sets to ask for the FIFO pacing thread.
PACING_RT_ENV = "ROBOT_CONTROLLER_PACING_RT_PRIORITY"

#: ``ROBOT_CONTROLLER_AFFINITY=0`` leaves every process free to run on any CPU.
AFFINITY_ENV = "ROBOT_CONTROLLER_AFFINITY"


#: processes that place their parts themselves: a robot's drive takes the loop's CPU, its ROS side the others
SELF_PLACED = ("robot",)


def loop_cpus() -> tuple[frozenset[int], frozenset[int]] | None:
    """The loop's CPU (the last allowed) and the others, or None where nothing is pinned (one CPU, or
    ``AFFINITY_ENV=0``)."""
    allowed = sorted(os.sched_getaffinity(0))
    if len(allowed) < 2 or os.environ.get(AFFINITY_ENV, "1") == "0":
        return None
    return frozenset(allowed[-1:]), frozenset(allowed[:-1])


@dataclass(frozen=True)
class Placement:
    nice: int
    cpus: frozenset[int] | None = None  #: None: wherever the kernel likes
    #: the nice of the process's scheduling group (autogroup) too, which is what ranks it against
    #: the other processes; False leaves the group at 0 (a wall-clock recorder, see apply_in_child)
    group_nice: bool = True


def placement(process_name: str, wall_clock: bool = True) -> Placement:
    """The loop's processes (a chain: one link runs at a time) share the last allowed CPU, the rest the others;
    on sim time, anywhere, at ``SIM_TIME_NICE``."""
    if not wall_clock:
        return Placement(nice=SIM_TIME_NICE.get(process_name, 0))
    cpus = None
    if (split := loop_cpus()) is not None and process_name not in SELF_PLACED:
        cpus = split[0] if process_name in LOOP_PROCESSES else split[1]
    nice = NICE.get(process_name, 0)
    return Placement(nice=nice, cpus=cpus, group_nice=nice < 0)


def apply_in_child(place: Placement) -> None:
    """In a child after the fork: its nice value, its session's autogroup nice (which ranks it against the
    other sessions) unless ``group_nice`` is False, and its CPUs; best effort."""
    try:
        os.setpriority(os.PRIO_PROCESS, 0, place.nice)
    except OSError:
        pass
    if place.nice and place.group_nice:
        try:
            with open("/proc/self/autogroup", "w") as autogroup:
                autogroup.write(str(place.nice))
        except OSError:
            pass  # no autogroup scheduling here, or not allowed
    if place.cpus:
        try:
            os.sched_setaffinity(0, place.cpus)
        except OSError:
            pass


def yield_to_the_loop() -> None:
    """In a helper process forked from a loop node (the law designer): the least urgent nice, and off the loop's CPU
    when the node was pinned to it, so its designs (ms of arithmetic each) never delay a tick; best effort. The
    session's autogroup is the node's too and is left as it is."""
    try:
        os.setpriority(os.PRIO_PROCESS, 0, 19)
    except OSError:
        pass
    pinned = os.sched_getaffinity(0)
    others = set(range(os.cpu_count() or 1)) - pinned
    if len(pinned) == 1 and others:
        try:
            os.sched_setaffinity(0, others)
        except OSError:
            pass  # a cpuset that allows only the loop's CPU: the nice alone


def realtime_thread_requested() -> int | None:
    value = os.environ.get(PACING_RT_ENV, "")
    try:
        return int(value) if value else None
    except ValueError:
        return None


_realtime_tids: list[int] = []
demoted = threading.Event()


def install_rt_budget(budget_us: int = RT_BUDGET_US) -> None:
    """Past ``budget_us`` of CPU without blocking, SIGXCPU demotes every thread made real-time here (main thread)."""
    # Past the hard limit the kernel kills the process (a thread spinning with the GIL starves the handler).
    resource.setrlimit(resource.RLIMIT_RTTIME, (budget_us, budget_us + 500_000))
    signal.signal(signal.SIGXCPU, _demote_all)


def make_current_thread_realtime(priority: int) -> str:
    """SCHED_FIFO at ``priority`` for the calling thread (after :func:`install_rt_budget`); a note for the log."""
    tid = threading.get_native_id()
    try:
        os.sched_setscheduler(tid, os.SCHED_FIFO, os.sched_param(priority))
    except OSError as exc:
        return f"real-time pacing not applied ({exc}); normal scheduling"
    _realtime_tids.append(tid)
    return f"pacing thread SCHED_FIFO {priority}, at most {RT_BUDGET_US / 1000:g} ms of CPU per wake-up"


def _demote_all(*_: object) -> None:
    for tid in _realtime_tids:
        try:
            os.sched_setscheduler(tid, os.SCHED_OTHER, os.sched_param(0))
        except OSError:
            pass
    demoted.set()
