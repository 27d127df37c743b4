"""The controller's missed cycles and watchdog ticks on the wall clock, told apart (ros/controller_ticks.py):
a period the host stretched (the loop's processes kept from a CPU as long as it ran over while other programs used
the CPUs, or the CPUs stolen) is the host's, any other the loop's; so is a watchdog tick, over the readings' silence
past the watchdog's window.
On stand-ins for the node and the loop's processes; the real /proc reads are tested in tests/nodes/simulator."""

from robot_controller.ros import loop_processes
from robot_controller.ros.controller_ticks import HostMisses
from robot_controller.ros.loop_processes import Sample

MS = 1_000_000


class ScriptedLoop:
    def __init__(self, *usages: tuple[int, ...] | None) -> None:
        self.usages = list(usages)

    def usage(self) -> Sample | None:
        """The next scripted (CPU, run-queue wait, steal[, other programs' CPU time]), ns, as one thread's sample;
        other programs busy all along unless said (a second a tick: any wait is theirs to excuse)."""
        usage = self.usages.pop(0)
        if usage is None:
            return None
        self.others_ns = usage[3] if len(usage) > 3 else getattr(self, "others_ns", 0) + 1_000_000_000
        return Sample({1: (1, *usage[:2])}, usage[2], self.others_ns)


def timing_at_100_hz(*usages: tuple[int, ...] | None) -> HostMisses:
    timing = object.__new__(HostMisses)  # the counting only: no scratch folder
    timing.control_period_s, timing.watchdog_periods = lambda: 0.01, lambda: 5
    timing.loop, timing.last_tick_s, timing.missed_for_host = ScriptedLoop(*usages), None, []
    timing.sampled, timing.sampled_s = None, -float("inf")
    timing.reading_s, timing.usage_at_reading, timing.reading_unsampled = None, None, False
    timing.watchdog_for_host = []
    return timing


def test_a_period_the_host_stretched_is_its_miss_and_one_it_did_not_is_the_loops(monkeypatch):
    monkeypatch.setattr(loop_processes, "_CPUS", 2)  # a host of two CPUs
    monkeypatch.setattr(loop_processes, "_TICK_NS", 10_000_000)  # whose steal counter moves in 10 ms steps
    timing = timing_at_100_hz(
        (0, 0, 0),
        (1 * MS, 0, 0),  # 10 ms: on time
        (2 * MS, 12 * MS, 0),  # 35 ms (20 over 1.5 periods), 12 ms waiting for a CPU: not enough
        (3 * MS, 12 * MS, 30 * MS),  # 35 ms, 30 ms stolen from two CPUs, in 10 ms steps: 10 ms certain, not enough
        (4 * MS, 32 * MS, 30 * MS),  # 35 ms, 20 ms waiting: the host's
        (5 * MS, 32 * MS, 80 * MS),  # 35 ms, 50 ms stolen: 20 ms of a CPU certain, the host's
    )
    for now_s in (0.0, 0.01, 0.045, 0.08, 0.115, 0.15):
        timing.note_tick(now_s)
    assert timing.missed_for_host == [0.115, 0.15]  # when each ended: metrics.json counts those it scores


def test_nothing_read_nothing_counted_for_the_host():
    timing = timing_at_100_hz(None, None)
    timing.note_tick(0.0)
    timing.note_tick(1.0)
    assert timing.missed_for_host == []


def test_a_watchdog_tick_is_the_hosts_only_if_it_kept_the_loop_waiting_past_the_window(monkeypatch):
    monkeypatch.setattr(loop_processes, "_CPUS", 2)
    monkeypatch.setattr(loop_processes, "_TICK_NS", 10_000_000)
    timing = timing_at_100_hz(
        (0, 0, 0),  # the reading arrives at 0: its tick samples the loop
        (1 * MS, 3 * MS, 0),  # 56 ms of silence, 6 past the 50 ms window: 3 ms waiting, the watchdog's own
        (2 * MS, 13 * MS, 0),  # 66 ms, 16 past: 13 ms waiting, still its own
        (3 * MS, 13 * MS, 50 * MS),  # 76 ms, 26 past: 13 ms waiting and 20 of a CPU stolen, the host's
    )
    timing.note_reading(0.0)
    for now_s, watchdog in ((0.0, False), (0.056, True), (0.066, True), (0.076, True)):
        timing.note_tick(now_s, watchdog)
    assert timing.watchdog_for_host == [0.076]
    assert timing.missed_for_host == []  # the 56 ms gap was the loop's own miss


def test_a_loop_that_keeps_its_own_processes_waiting_is_late_by_its_own_fault(monkeypatch):
    """Its processes waited for a CPU, but nothing else used one: the loop overloads its own cores (the Panda at
    1 kHz in one process ran at 741 Hz, its misses all excused as the host's). Other programs' CPU time excuses the
    wait only as far as it goes."""
    monkeypatch.setattr(loop_processes, "_CPUS", 2)
    monkeypatch.setattr(loop_processes, "_TICK_NS", 10_000_000)
    timing = timing_at_100_hz(
        (0, 0, 0, 0),
        (20 * MS, 30 * MS, 0, 10 * MS),  # 35 ms (20 over 1.5 periods), 30 ms waiting, others one counter step: its own
        (40 * MS, 60 * MS, 0, 40 * MS),  # 35 ms, 30 ms waiting, others 20 ms beyond that step: 20 ms, the host's
        (60 * MS, 90 * MS, 0, 60 * MS),  # 35 ms, 30 ms waiting, others 10 ms beyond it: not enough, its own
    )
    for now_s in (0.0, 0.035, 0.07, 0.105):
        timing.note_tick(now_s)
    assert timing.missed_for_host == [0.07]


class CountingLoop(ScriptedLoop):
    def __init__(self, *usages: tuple[int, ...] | None) -> None:
        super().__init__(*usages)
        self.reads = 0

    def usage(self) -> Sample | None:
        self.reads += 1
        return super().usage()


def test_at_1_khz_the_loops_usage_is_read_every_5_ms_and_at_every_long_period(monkeypatch):
    """Reading it costs about 0.1 ms: at every 1 ms tick it was a tenth of the loop. A long period is still judged,
    from the usage read last before it."""
    monkeypatch.setattr(loop_processes, "_CPUS", 2)
    monkeypatch.setattr(loop_processes, "_TICK_NS", 10_000_000)
    timing = timing_at_100_hz()
    timing.control_period_s = lambda: 0.001
    timing.loop = CountingLoop(*[(k * MS // 10, 0, 0) for k in range(3)], (MS, 30 * MS, 0))
    ticks_s = [k * 0.001 for k in range(13)] + [0.040]  # 13 on time, then a 28 ms period: 30 ms waiting for a CPU
    for now_s in ticks_s:
        timing.note_tick(now_s)
    assert timing.loop.reads == 3 + 1  # at 0, 5 and 10 ms, and at the long period's end
    assert timing.missed_for_host == [0.040]
