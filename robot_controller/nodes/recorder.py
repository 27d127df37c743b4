"""recorder: the topics ``blocks.spec`` records, raw (CDR), into an MCAP bag, as ``ros2 bag record`` would, below
the loop (nice +10). On sim time it publishes the tick it has taken (port ``recorder_clock``); the simulator holds
while it lags. Tells the launcher ``@ready``, then ``@progress {json}``; on SIGINT/SIGTERM it records until the topics
are quiet (still reporting), closes the bag, then tears DDS down under an alarm.
``python -m robot_controller.nodes.recorder BAG_DIR [--sim-time]``"""

from __future__ import annotations

import argparse
import json
import struct
import sys
import time
from pathlib import Path

import rclpy
from rclpy.node import Node
from rosgraph_msgs.msg import Clock

from robot_controller.blocks import spec
from robot_controller.ros.messages import message_class
from robot_controller.ros.process import make_executor, own_context, work_done_teardown_left
from robot_controller.ros.publishing import RECORDER_NODE
from robot_controller.ros.qos import CLOCK_QOS, CONTROL_QOS

# Reliable with a deep queue: the recorder runs below the loop and may be late, never lossy.
RECORDER_QOS = CONTROL_QOS

PROGRESS_PERIOD_S = 0.1
BATCH_PERIOD_S = 0.005
TAKE_BUDGET_S = 0.05  #: the longest one batch takes before the progress and checkpoint get their turn
CHECKPOINT_PERIOD_S = 1.0  #: of wall time and, on sim time, of the run's clock (a short run may outpace the wall)
# A larger message is dropped and counted: the loop's are under a kilobyte; a peer's must not fill the disk.
MAX_MESSAGE_BYTES = 64 * 1024
DRAIN_QUIET_S = 0.15
# After the stop, the readers' queues are taken while they hold any (seconds on a loaded machine), this long at most.
DRAIN_MAX_S = 15.0
READY_LINE = "@ready"
PROGRESS_PREFIX = "@progress "


def topics_for(sim_time: bool) -> dict[str, tuple[type, str]]:
    """topic → (ROS message class, rosbag2 type name): every port ``blocks.spec`` records (``sim_time``: sim time)."""
    return {p.topic: (message_class(p.msg_type), p.msg_type) for p in spec.recorded_ports(sim_time)}


#: The sim's next tick is at most a control period past the last (10 Hz at the slowest): later is no tick of its.
MAX_TICK_AHEAD_NS = 1_000_000_000


def clock_ns_of(cdr: bytes) -> int:
    """``rosgraph_msgs/Clock`` time from its CDR bytes (little-endian: encapsulation 0x0001), or a stamped message's
    header stamp (first in it the same way)."""
    if len(cdr) < 12:
        return 0  # not one of the sim's: nothing to learn the time from
    sec, nanosec = struct.unpack_from("<iI" if cdr[1] == 1 else ">iI", cdr, 4)
    return sec * 1_000_000_000 + nanosec


class Recorder:
    """Writes every message of ``topics`` to ``bag_dir`` as it arrives."""

    def __init__(self, context, bag_dir: Path, *, sim_time: bool) -> None:
        # rosbags is imported here, in the recorder's own process (the launcher forks all from one image).
        from rosbags.rosbag2 import StoragePlugin, Writer
        from rosbags.typesys import Stores, get_typestore

        self.node = Node(RECORDER_NODE, context=context, start_parameter_services=False)
        self.sim_time = sim_time
        #: sim time: the bag's time base, the sim's latest tick (its clock, or its true state's stamp just before)
        self.clock_ns = 0
        self.clock_taken_s = 0.0  #: when (monotonic s) the latest tick of the time base was taken
        self.writer = Writer(bag_dir, version=9, storage_plugin=StoragePlugin.MCAP)
        self.writer.open()
        self.counts = {topic: 0 for topic in topics_for(sim_time)}
        self.taken = 0  #: messages taken from DDS, recorded or not: how a batch knows it took them all
        self.oversize: dict[str, int] = {}  #: messages over MAX_MESSAGE_BYTES, dropped, per topic
        self.last_message = time.monotonic()
        self.next_checkpoint_s = time.monotonic()  #: monotonic s
        self.next_checkpoint_clock_ns = 0  #: sim time: the run's clock, ns
        self.clock_pub = self.node.create_publisher(Clock, spec.RECORDER_CLOCK.topic, CLOCK_QOS) if sim_time else None
        typestore = get_typestore(Stores.ROS2_JAZZY)
        for topic, (msg_class, type_name) in topics_for(sim_time).items():
            connection = self.writer.add_connection(topic, type_name, typestore=typestore)
            self.node.create_subscription(msg_class, topic, self._callback(topic, connection), RECORDER_QOS, raw=True)

    def _callback(self, topic: str, connection):
        write = self.writer.write
        counts = self.counts
        sets_time_base = topic in (spec.CLOCK.topic, spec.TRUE_STATE.topic) and self.sim_time

        def record(data: bytes) -> None:
            self.taken += 1
            if len(data) > MAX_MESSAGE_BYTES:  # no message of the loop is near this: a hostile peer's
                self.oversize[topic] = self.oversize.get(topic, 0) + 1
                return
            if sets_time_base:
                stamp_ns = clock_ns_of(data)
                # A new tick (the first is at 0); never one far ahead: a peer's stamp would end the run's recording.
                if (
                    stamp_ns > self.clock_ns or not self.clock_taken_s
                ) and stamp_ns - self.clock_ns < MAX_TICK_AHEAD_NS:
                    self.clock_ns, self.clock_taken_s = max(stamp_ns, self.clock_ns), time.monotonic()
            write(connection, self.clock_ns if self.sim_time else time.time_ns(), data)
            counts[topic] += 1
            self.last_message = time.monotonic()

        return record

    def take_waiting(self, executor) -> None:
        """The messages waiting now, one per ``spin_once``, until none or ``TAKE_BUDGET_S`` (progress goes on)."""
        spin_once = executor.spin_once
        give_up = time.monotonic() + TAKE_BUDGET_S
        while True:
            before = self.taken
            spin_once(timeout_sec=0.0)
            if self.taken == before or time.monotonic() > give_up:
                return

    def say_clock(self) -> None:
        """On sim time: publish the tick taken last (every progress period, not every batch)."""
        if self.clock_pub is None:
            return
        msg = Clock()
        msg.clock.sec, msg.clock.nanosec = divmod(self.clock_ns, 1_000_000_000)
        self.clock_pub.publish(msg)

    def checkpoint_when_due(self, now: float) -> None:
        """A checkpoint every ``CHECKPOINT_PERIOD_S`` of wall time and of the run's clock: sim time may run a short
        run faster than the wall, which would leave a killed recorder with no whole chunk."""
        if now < self.next_checkpoint_s and self.clock_ns < self.next_checkpoint_clock_ns:
            return
        self.next_checkpoint_s = now + CHECKPOINT_PERIOD_S
        self.next_checkpoint_clock_ns = self.clock_ns + int(CHECKPOINT_PERIOD_S * 1e9)
        self.checkpoint()

    def checkpoint(self) -> None:
        """Close the chunk being written and push it to the file: a killed recorder's bag is recoverable but for the
        last ``CHECKPOINT_PERIOD_S`` (rosbags has no public call for it)."""
        storage = getattr(self.writer, "storage", None)
        chunk = getattr(storage, "chunk", None)
        if chunk is None or not hasattr(storage, "close_chunk") or not chunk.bio.tell():
            return
        storage.close_chunk()
        storage.bio.flush()

    def progress(self) -> str:
        progress = {"counts": self.counts, "clock_s": self.clock_ns * 1e-9, "clock_taken_s": self.clock_taken_s}
        return PROGRESS_PREFIX + json.dumps(progress | {"oversize": self.oversize})


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="recorder")
    parser.add_argument("bag_dir", type=Path)
    parser.add_argument("--sim-time", action="store_true")
    args = parser.parse_args(None if argv is None else argv[1:])  # argv[0] is the program, as for rclpy
    context, stop = own_context()
    recorder = Recorder(context, args.bag_dir, sim_time=args.sim_time)
    executor = make_executor(context)
    executor.add_node(recorder.node)
    print(READY_LINE, flush=True)
    next_progress = time.monotonic()

    def report_progress(now: float) -> None:
        nonlocal next_progress
        if now >= next_progress:
            next_progress += PROGRESS_PERIOD_S
            recorder.say_clock()
            print(recorder.progress(), flush=True)

    try:
        while not stop.wait(BATCH_PERIOD_S):
            recorder.take_waiting(executor)
            report_progress(now := time.monotonic())
            recorder.checkpoint_when_due(now)
        # The nodes stop first; take what is still in flight, reporting (the launcher waits while it hears us).
        stopped = time.monotonic()
        deadline = stopped + DRAIN_MAX_S
        while time.monotonic() - max(recorder.last_message, stopped) < DRAIN_QUIET_S and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.05)
            report_progress(time.monotonic())
    finally:
        recorder.writer.close()  # the bag whole before the DDS teardown, which can hang
    print(recorder.progress(), flush=True)
    work_done_teardown_left()  # a hang from here on ends by its alarm: a warning, the bag is closed
    executor.shutdown(timeout_sec=1.0)
    recorder.node.destroy_node()
    rclpy.try_shutdown(context=context)
    return 0


if __name__ == "__main__":
    sys.exit(main())
