"""The default run's paced world (ros/clocks/paced.py): a host that freezes every process of the
loop together is no fault, a controller that freezes alone is. Real nodes over DDS, each test on its own
domain; figures are judged against what the host did (its freezes, the loop's late efforts), never a
bare timing threshold. Last, on stand-ins, the pacing thread's decisions at a deadline."""

import json
import os
import signal
import subprocess
import time

import pytest

from robot_controller.experiments.faults import case_figures
from robot_controller.scoring import report
from tests.rostools import child_pid, run_said, run_while

pytestmark = pytest.mark.ros

NODES = ("simulator", "motor_node", "sensor_node", "pid_controller", "trajectory_planner")
FREEZES = 3


def freeze(pids: list[int], freeze_s: float) -> None:
    for pid in pids:
        os.kill(pid, signal.SIGSTOP)
    time.sleep(freeze_s)
    for pid in reversed(pids):  # the world (first) resumes last, as a whole host's freeze ends for all at once
        os.kill(pid, signal.SIGCONT)


def frozen_run(tmp_path, nodes: tuple[str, ...], freeze_s: float) -> tuple[dict, str, report.Recording]:
    """A 10 s default run whose ``nodes`` are frozen together ``FREEZES`` times for ``freeze_s``, 2.5 s apart."""
    out = tmp_path / "run"

    def act(launcher: subprocess.Popen) -> None:
        pids = [child_pid(launcher, name) for name in nodes]
        for _ in range(FREEZES):
            time.sleep(2.5)
            freeze(pids, freeze_s)

    code, output = run_while(out, act, duration="10")
    metrics = json.loads((out / "metrics.json").read_text())
    assert code == (0 if metrics["verdict"] == "ok" else 1), run_said(output)  # a verdict, not a crash
    return metrics, output, report.read_recording(out / "bag")


def test_the_whole_loop_frozen_together_is_the_hosts_freeze_and_no_fault(tmp_path, ros_domain):
    metrics, output, _ = frozen_run(tmp_path, NODES, 0.05)
    assert metrics["clock"] == "sim_paced"
    assert metrics["host_freezes"] >= FREEZES, metrics  # each seen by the world (and the host's own, if any)
    assert metrics["host_freeze_ms_max"] >= 40.0, metrics
    assert metrics["watchdog_ticks"] == 0 and metrics["stopped_ticks"] == 0, metrics
    assert metrics["verdict"] == "ok", metrics["verdict_reasons"]  # the host's freeze: no fault of the loop's
    assert "brakes on" not in output
    # A freeze of the world costs no tracking; a busy host's late efforts (counted) cost a period each.
    late = metrics["late_efforts"] + metrics.get("late_efforts_host", 0)
    assert metrics["tracking_max_rad"] <= 0.006 + 0.001 * late, metrics


def test_the_controller_frozen_alone_is_its_stall_and_the_arm_stays_in_its_band(tmp_path, ros_domain):
    metrics, output, recording = frozen_run(tmp_path, ("pid_controller",), 0.08)
    # Each freeze: the world waited drive_timeout_s (50 ms) for the effort, braked, and went on without it.
    assert metrics["late_efforts"] >= FREEZES, metrics
    # The world braked the arm at every freeze: only the simulator's own hiccups meanwhile (beside a CPU hog) are
    # excused, never the rest of the controller's stall; unless the simulator froze through most of it too (its
    # publishing held up by the stopped reader, seen in 1 of 9 freezes on a loaded host: the world paused with it).
    # The controller may skip the ticks it slept through (missed cycles) or take them all late from its backlog:
    # its missed cycles are not a count of the freezes.
    assert metrics["brake_engagements"] >= FREEZES - (metrics["host_freeze_ms_max"] >= 60.0), metrics
    assert "no effort for 0.05 s" in output, run_said(output)
    # Its stall: a fault (the swing back may also take the arm past the band).
    assert any(reason.startswith("the brakes held the arm") for reason in metrics["verdict_reasons"]), metrics
    # Back, it starts from where the brakes hold the arm: its newest reading, from before them, is not advanced
    # on the arm's speed (it was, once: a 0.11 rad error at the first tick beside a hog).
    assert metrics["tracking_max_rad"] <= 0.05 and metrics["peak_torque_nm"] < 10.0, metrics
    figures = case_figures(recording, recording.true_time_s[0], recording.true_time_s[-1])
    assert figures["brake_engaged"] and figures["max_deviation_rad"] <= 0.1, figures


def test_the_motor_frozen_alone_brakes_the_arm_and_the_controller_takes_it_back_without_a_swing(tmp_path, ros_domain):
    """The controller goes on ticking while its commands stop reaching the arm: it must hear the brakes (and
    re-acquire from where they held the arm), and the commands the freeze held up must never be applied.
    Before both, a 0.3 s freeze mid-swing left the arm 0.87 rad off its reference, driven at the 10 N·m limit."""
    metrics, output, _ = frozen_run(tmp_path, ("motor_node",), 0.3)
    assert metrics["brake_engagements"] >= 1 and metrics["stale_efforts"] >= 1, metrics
    assert "a stale effort is no effort" in output, run_said(output)
    assert metrics["verdict"] == "failed", metrics  # braked for a fault
    assert metrics["tracking_max_rad"] <= 0.05, metrics
    assert metrics["peak_torque_nm"] < 10.0, metrics  # the arm's limit: never driven there to catch up


# --- the pacing thread's decisions at a deadline, on stand-ins for the world and its sim-time ticks ---


class StandInTicks:
    ended, published, efforts_applied, held_for_recorder, end_ns = False, 1, 1, False, None

    def __init__(self) -> None:
        self.advanced = 0

    def advance(self) -> None:
        self.advanced += 1

    def accept(self, effort) -> None:
        self.accepted = effort


class StandInWorld:
    """The world block as the paced clock sees it: its time and why its brakes hold."""

    def __init__(self) -> None:
        self.reasons: set[str] = set()
        self.time_ns = 0

    @property
    def time_s(self) -> float:
        return self.time_ns * 1e-9

    @property
    def estopped(self) -> bool:
        return "estop" in self.reasons

    def braked_for(self, reason: str) -> bool:
        return reason in self.reasons

    def set_brake(self, reason: str, on: bool) -> list:
        (self.reasons.add if on else self.reasons.discard)(reason)
        return []


class StandInLoop:
    """The loop's processes as ``ros.loop_processes`` reads them, scripted: one ``Usage`` a call."""

    def __init__(self, *usages, stopped: bool = False) -> None:
        self.usages, self.stopped = list(usages), stopped

    def usage(self):
        return self.usages.pop(0) if self.usages else None

    def any_stopped(self) -> bool:
        return self.stopped


def paced_at_100_hz():
    import threading
    from types import SimpleNamespace

    from robot_controller.ros.clocks.host import FreezeLog, Pacing
    from robot_controller.ros.clocks.paced import PacedClock

    paced = object.__new__(PacedClock)  # the decisions only: no world, no host, no thread
    paced.world = StandInWorld()
    paced.out = SimpleNamespace(write=lambda written: None)
    paced.log = SimpleNamespace(info=lambda text: None, warn=lambda key, text: None)
    paced.lock = threading.Lock()
    paced.drive_timeout_s = 0.05
    paced.ticks = StandInTicks()
    paced.period_ns, paced.timeout_ns, paced.late_ns = 10_000_000, 50_000_000, 10_000_000
    paced.effort_in, paced.late_efforts, paced.late_for_host, paced.after_estop = False, 0, 0, False
    paced.stale_ns, paced.stale_efforts, paced.loop_heard = 10_000_000, 0, False
    paced.loop, paced.wait_usage = StandInLoop(), None
    paced.freezes = FreezeLog()
    paced.effort_arrived = threading.Condition(paced.lock)
    paced.pacing = Pacing(paced.log)
    return paced


def test_an_effort_in_time_steps_the_world_on_its_grid_and_is_no_miss():
    paced = paced_at_100_hz()
    paced.effort_in = True
    assert paced.tick(deadline_ns=0, now_ns=2_000_000, waited_ns=0) == 10_000_000
    assert paced.ticks.advanced == 1 and paced.late_efforts == 0 and not paced.world.reasons


def test_the_world_waits_for_a_late_effort_counts_it_and_does_not_catch_up():
    paced = paced_at_100_hz()
    paced.effort_in = True
    assert paced.tick(deadline_ns=0, now_ns=30_000_000, waited_ns=30_000_000) == 30_000_000
    assert paced.ticks.advanced == 1 and paced.late_efforts == 1 and not paced.world.reasons


def test_an_effort_the_host_kept_waiting_is_not_the_loops_miss_and_one_it_did_not_is(monkeypatch):
    from robot_controller.ros import loop_processes
    from robot_controller.ros.loop_processes import Sample

    monkeypatch.setattr(loop_processes, "_CPUS", 2)
    monkeypatch.setattr(loop_processes, "_TICK_NS", 10_000_000)

    def late_by_25_ms(before: Sample, after: Sample) -> tuple[int, int]:
        paced = paced_at_100_hz()
        paced.wait_usage, paced.loop, paced.effort_in = before, StandInLoop(after), True
        paced.tick(deadline_ns=0, now_ns=25_000_000, waited_ns=25_000_000)
        return paced.late_efforts, paced.late_for_host

    ms = 1_000_000
    start = Sample({1: (100, 0, 0), 2: (200, 0, 0), 3: (200, 0, 0)}, 0)
    # 15 ms past the period it may take. Two processes each waited 8 ms for a CPU, one after the other, while other
    # programs used 25 ms of CPU time (a step of their counter uncertain): the host's.
    waited = {1: (100, 0, 8 * ms), 2: (200, 0, 8 * ms), 3: (200, 0, 0)}
    assert late_by_25_ms(start, Sample(waited, 0, 35 * ms)) == (0, 1)
    # The same waits with nothing else running: the loop's processes kept each other waiting, its own.
    assert late_by_25_ms(start, Sample(waited, 0, 0)) == (1, 0)
    # Two threads of one process waited 8 ms side by side: 8 ms of the loop's time, not 16: its own.
    assert late_by_25_ms(start, Sample({1: (100, 0, 0), 2: (200, 0, 8 * ms), 3: (200, 0, 8 * ms)}, 0, 35 * ms)) == (
        1,
        0,
    )
    # The hypervisor stole 40 ms of the host's two CPUs' time (its counter in 10 ms steps): 15 ms a CPU, the host's.
    assert late_by_25_ms(start, Sample(start.threads, 40 * ms)) == (0, 1)
    # One step of the counter (10 ms over two CPUs) may be almost nothing: its own.
    assert late_by_25_ms(start, Sample(start.threads, 10 * ms)) == (1, 0)


def test_the_loops_processes_are_read_from_the_pids_its_nodes_leave(tmp_path, monkeypatch):
    import os

    from robot_controller.ros.loop_processes import LoopProcesses, leave_pid
    from robot_controller.ros.publishing import COUNTS_DIR_ENV

    assert LoopProcesses(str(tmp_path)).usage() is None  # no node has left its pid: nothing measured
    monkeypatch.setenv(COUNTS_DIR_ENV, str(tmp_path))
    leave_pid("pid_controller")
    loop = LoopProcesses(str(tmp_path))
    before = loop.usage()
    sum(range(2_000_000))  # this process's main thread runs a while
    after = loop.usage()
    loop.close()
    assert (tmp_path / "pid.pid_controller").read_text() == str(os.getpid())
    assert before is not None and after is not None and os.getpid() in before.threads  # its main thread's id
    assert (after - before).cpu_ns > 0


def test_no_effort_within_the_drive_timeout_brakes_and_the_world_goes_on_without_waiting():
    paced = paced_at_100_hz()
    with paced.effort_arrived:
        waited_ns = paced.wait_for_effort(time.monotonic_ns())
    assert waited_ns >= paced.timeout_ns or paced.freezes.count  # (a host freeze meanwhile is not the loop's)
    paced.tick(deadline_ns=0, now_ns=waited_ns, waited_ns=waited_ns)
    assert paced.world.reasons == {"drive_timeout"} and paced.ticks.advanced == 1 and paced.late_efforts == 1
    with paced.effort_arrived:
        assert paced.wait_for_effort(time.monotonic_ns()) == 0  # braked: no more waiting


def test_the_ticks_an_estop_holds_back_are_not_the_loops_late_efforts():
    """The e-stop is asked for: the efforts it stops (the motor drops the commands) are no miss of the loop's, until
    the first effort after its release (it said 426 late efforts, the loop's own, after a 4 s e-stop)."""
    paced = paced_at_100_hz()
    paced.world.set_brake("estop", True)
    for k in range(5):
        paced.tick(deadline_ns=k * paced.period_ns, now_ns=k * paced.period_ns, waited_ns=0)
    paced.world.set_brake("estop", False)  # released: the brakes wait for the drive's next effort
    paced.tick(deadline_ns=5 * paced.period_ns, now_ns=5 * paced.period_ns, waited_ns=0)
    assert paced.late_efforts == 0 and paced.ticks.advanced == 6
    paced.effort_in = True  # the loop is back
    paced.tick(deadline_ns=6 * paced.period_ns, now_ns=6 * paced.period_ns, waited_ns=0)
    paced.tick(deadline_ns=7 * paced.period_ns, now_ns=7 * paced.period_ns, waited_ns=0)  # and then misses one
    assert paced.late_efforts == 1


def test_an_effort_held_up_while_the_brakes_took_the_arm_is_dropped_and_a_fresh_one_is_taken():
    """Seen in a run beside a flood: the effort for t = 1.59 s, 10 N·m on a reading the brakes had just stopped,
    reached the world at 1.76 s; applied, it released the brakes with a kick (30 mrad)."""
    import numpy as np

    paced = paced_at_100_hz()
    paced.world.time_ns = 1_760_000_000  # the world, at 1 ms a step, is at 1.76 s
    paced.take_effort(np.array([10.0]), tick_ns=1_590_000_000)
    assert paced.stale_efforts == 1 and not paced.effort_in and not hasattr(paced.ticks, "accepted")
    paced.take_effort(np.array([2.0]), tick_ns=1_750_000_000)  # computed for the tick before the world's: in time
    assert paced.effort_in and paced.ticks.accepted.tolist() == [2.0]
    paced.take_effort(np.array([3.0]))  # a controller that does not stamp its ticks (the tutorial's): taken
    assert paced.ticks.accepted.tolist() == [3.0] and paced.stale_efforts == 1


def test_a_loop_slower_than_a_period_is_waited_for_again_once_its_stale_effort_shows_it_alive():
    """Braked for the drive timeout, the world goes on without waiting: a loop 30 ms slow would send only stale
    efforts, and stay braked for good. Its first stale effort makes the next tick wait for its effort again."""
    import numpy as np

    paced = paced_at_100_hz()
    paced.world.reasons.add("drive_timeout")
    paced.world.time_ns = 2_000_000_000
    with paced.effort_arrived:
        assert paced.wait_for_effort(time.monotonic_ns()) == 0  # braked, nothing heard: no waiting
    paced.take_effort(np.array([1.0]), tick_ns=1_970_000_000)
    assert paced.stale_efforts == 1 and paced.loop_heard
    with paced.effort_arrived:
        waited_ns = paced.wait_for_effort(time.monotonic_ns())
    assert waited_ns >= paced.timeout_ns or paced.freezes.count  # it waited (a host freeze meanwhile restarts it)
    paced.tick(deadline_ns=0, now_ns=waited_ns, waited_ns=waited_ns)
    assert not paced.loop_heard  # none came: the world goes on without waiting again


def test_freezes_are_counted_with_their_longest_and_total():
    from robot_controller.ros.clocks.host import FreezeLog

    freezes = FreezeLog()
    freezes.note(60_000_000)
    freezes.note(20_000_000)
    assert freezes.figures() == {"host_freezes": 2, "host_freeze_ms_max": 60.0, "host_freeze_ms_total": 80.0}


class ScriptedWait:
    """The world's wait on a scripted clock: each wait lasts its timeout, and the ``gaps`` (ms of wall time after
    that many waits) are the simulator's own, spent waiting for a CPU (``busy``) or stopped with everything."""

    def __init__(self, gaps: dict[int, float], busy: bool) -> None:
        self.now_ns, self.run_wait_s, self.calls, self.gaps, self.busy = 0, 0.0, 0, gaps, busy

    def wait(self, timeout_s: float) -> None:
        self.now_ns += round(timeout_s * 1e9)
        gap_ms = self.gaps.get(self.calls, 0.0)
        self.now_ns += round(gap_ms * 1e6)
        self.run_wait_s += gap_ms * 1e-3 if self.busy else 0.0
        self.calls += 1


def scripted_wait(
    monkeypatch, gaps: dict[int, float], busy: bool, *, host_froze: bool = False, stopped: bool = False
) -> tuple[int, int, int]:
    """The time waited for an effort that never comes (the world woken by a freeze of the host's if ``host_froze``;
    a process of the loop ``stopped`` meanwhile), the wall time that took, and the gaps seen (ns, ns, count)."""
    from types import SimpleNamespace

    from robot_controller.ros.clocks import paced as paced_module

    script = ScriptedWait(gaps, busy)
    monkeypatch.setattr(paced_module, "time", SimpleNamespace(monotonic_ns=lambda: script.now_ns))
    monkeypatch.setattr(paced_module, "process_run_wait_s", lambda: script.run_wait_s)
    paced = paced_at_100_hz()
    paced.effort_arrived, paced.loop = script, StandInLoop(stopped=stopped)
    waited_ns = paced.wait_for_effort(0, host_froze)
    return waited_ns, script.now_ns, paced.freezes.count


def test_a_controllers_stall_is_timed_whatever_the_simulator_did_meanwhile(monkeypatch):
    """The controller alone stalls; 20 ms into the world's wait the simulator is kept 30 ms from a CPU (a busy host).
    Only those 30 ms are excused: the drive timeout (50 ms of the simulator's own time) ends the wait 80 ms in, and
    the world brakes. Restarting the wait at the gap, as it once did, let an 80 ms stall through (1 brake in 3)."""
    waited_ns, wall_ns, gaps = scripted_wait(monkeypatch, {1: 30.0}, busy=True)
    assert (waited_ns, wall_ns, gaps) == (50_000_000, 80_000_000, 1)


def test_a_freeze_of_the_whole_host_early_in_the_wait_leaves_time_for_dds_to_repair(monkeypatch):
    """Every process stopped together for 50 ms, the effort not yet late: the wait goes on for two drive timeouts of
    the simulator's own time (DDS's heartbeat repairs a message the freeze lost)."""
    waited_ns, wall_ns, gaps = scripted_wait(monkeypatch, {0: 50.0}, busy=False)
    assert (waited_ns, wall_ns, gaps) == (100_000_000, 150_000_000, 1)


def test_a_freeze_once_the_effort_is_late_is_excused_and_no_more(monkeypatch):
    """The controller already 20 ms late when everything stops: its stall was its own before the freeze."""
    waited_ns, wall_ns, gaps = scripted_wait(monkeypatch, {2: 50.0}, busy=False)
    assert (waited_ns, wall_ns, gaps) == (50_000_000, 100_000_000, 1)


def test_a_controller_stopped_just_after_a_freeze_of_the_host_is_timed_as_its_own_stall(monkeypatch):
    """The world woke late from the host's freeze (two drive timeouts to wait), and the controller was stopped just
    then: seen stopped at the first slice, its stall is its own and the world brakes after one drive timeout."""
    assert scripted_wait(monkeypatch, {}, busy=False, host_froze=True, stopped=True) == (50_000_000, 50_000_000, 0)
    assert scripted_wait(monkeypatch, {}, busy=False, host_froze=True) == (100_000_000, 100_000_000, 0)


def test_the_worlds_own_gap_while_the_controller_is_stopped_is_the_controllers(monkeypatch):
    """Stopped, the controller's reader holds up the world's messages to it: the world's gap of 28 ms meanwhile was
    excused, and the wait outlasted an 80 ms SIGSTOP (1 brake in 3, 1 run in 10). Counted, the world brakes at 50 ms
    of wall time; a busy host's gap with nothing stopped is excused as before."""
    assert scripted_wait(monkeypatch, {1: 28.0}, busy=False, stopped=True) == (50_000_000, 50_000_000, 0)
    assert scripted_wait(monkeypatch, {1: 28.0}, busy=True)[:2] == (50_000_000, 78_000_000)
