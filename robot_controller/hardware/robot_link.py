"""What passes between a robot's drive process (the loop at the robot's 1 kHz) and its ROS side, through memory both
share: the planner's newest sample one way, requests (e-stop, end) as flags, each tick's record the other way. The
drive never waits on it: a stopped or slow ROS side costs the loop nothing (a pipe or a Python thread would: a thread
of the same interpreter held the loop from the GIL for 10 ms at a time, and a full pipe blocks its writer).

Memory order: on this host's (x86-64) stores are seen in the order made, so a writer that fills a slot and then moves
its counter is read whole by a reader that checks the counter before and after."""

from __future__ import annotations

import mmap
from dataclasses import dataclass

import numpy as np

#: the robot's state and the controller's are published every this many ticks: 100 Hz at the robot's 1 kHz, as the
#: simulated loop's (every tick's figures are the drive's, in its diagnostics and the timing file). At 1 kHz the
#: planner, which hears the controller's state during a goal, fell behind on its samples and the goal's reference
#: came in steps; and each message costs its publisher and every reader about 0.1 ms of CPU.
TELEMETRY_EVERY = 10
#: ticks the record holds: 4 s at 1 kHz, for a ROS side that reads every 10 ms
RING_TICKS = 4096
#: requests, by their flag's index: an e-stop, the run's end, the graph ready for the first tick
ESTOP, END, GO = 0, 1, 3
#: what the drive says of its motion, at this flag's index (one of ``PHASES``)
PHASE = 2
PHASES = ("starting", "moving", "stopping", "ended", "estopped", "fault")


@dataclass(frozen=True)
class TickRow:
    """One tick's record, as the drive lays it out: the robot's state and the controller's state row."""

    time_s: float  #: the tick, on the ROS side's clock (epoch s)
    compute_s: float  #: from the state's arrival to the command's writing
    success_rate: float  #: the robot's ``control_command_success_rate``
    missed: float  #: periods that passed without a state before this one
    position: np.ndarray
    velocity: np.ndarray
    torque_nm: np.ndarray  #: measured, gravity included
    state: np.ndarray  #: the controller's state row (port ``state``)


class RobotLink:
    """The shared memory, made before the drive is forked (anonymous, inherited): ``joint_count`` joints, controller
    state rows of ``state_size``."""

    HEAD = 4  # time_s, compute_s, success_rate, missed

    def __init__(self, joint_count: int, state_size: int) -> None:
        n = joint_count
        self.joint_count, self.state_size = n, state_size
        self.row_size = self.HEAD + 3 * n + state_size
        sizes = {"reference": 2 + 3 * n, "flags": 8, "ring": RING_TICKS * self.row_size, "count": 1}
        self._memory = mmap.mmap(-1, 8 * sum(sizes.values()))
        buffer = np.frombuffer(self._memory, dtype=np.float64)
        parts, at = {}, 0
        for name, size in sizes.items():
            parts[name] = buffer[at : at + size]
            at += size
        self._reference = parts["reference"]  # [sequence, sample_time_s, q…, q̇…, q̈…]
        self._flags = parts["flags"]
        self._ring = parts["ring"].reshape(RING_TICKS, self.row_size)
        self._count = parts["count"]  # rows ever written
        self._reference_seen = 0.0
        self._read = 0

    # --- the ROS side writes, the drive reads -----------------------------------------------

    def offer_reference(self, sample_time_s: float, sample: np.ndarray) -> None:
        """The planner's newest sample ``[q…, q̇…, q̈…]`` taken at ``sample_time_s``."""
        slot = self._reference
        slot[0] += 1  # odd: being written
        slot[1] = sample_time_s
        slot[2:] = sample
        slot[0] += 1

    def request(self, flag: int) -> None:
        self._flags[flag] = 1.0

    def new_reference(self) -> tuple[float, np.ndarray] | None:
        """The sample offered since the last call, whole, or None."""
        slot = self._reference
        sequence = slot[0]
        if sequence == self._reference_seen or int(sequence) % 2:
            return None
        time_s, sample = float(slot[1]), slot[2:].copy()
        if slot[0] != sequence:  # overwritten while copied: the next tick takes the newer one
            return None
        self._reference_seen = sequence
        return time_s, sample

    def requested(self, flag: int) -> bool:
        return bool(self._flags[flag])

    # --- the drive writes, the ROS side reads ----------------------------------------------

    def say_phase(self, phase: str) -> None:
        self._flags[PHASE] = PHASES.index(phase)

    def phase(self) -> str:
        return PHASES[int(self._flags[PHASE])]

    def record(
        self, time_s: float, compute_s: float, success_rate: float, missed: int, position, velocity, torque_nm, state
    ) -> None:
        n, count = self.joint_count, int(self._count[0])
        row = self._ring[count % RING_TICKS]
        row[: self.HEAD] = (time_s, compute_s, success_rate, missed)
        at = self.HEAD
        row[at : at + n], row[at + n : at + 2 * n], row[at + 2 * n : at + 3 * n] = position, velocity, torque_nm
        row[at + 3 * n :] = state
        self._count[0] = count + 1

    def rows(self) -> tuple[list[TickRow], int]:
        """The ticks recorded since the last call, oldest first, and how many were overwritten before they were read
        (a ROS side held up over ``RING_TICKS`` periods)."""
        count = int(self._count[0])
        lost = max(0, count - self._read - RING_TICKS)
        start = self._read + lost
        taken = self._ring[[k % RING_TICKS for k in range(start, count)]].copy() if count > start else None
        self._read = count
        if taken is None:
            return [], lost
        n, at = self.joint_count, self.HEAD
        return [
            TickRow(
                time_s=float(row[0]),
                compute_s=float(row[1]),
                success_rate=float(row[2]),
                missed=float(row[3]),
                position=row[at : at + n],
                velocity=row[at + n : at + 2 * n],
                torque_nm=row[at + 2 * n : at + 3 * n],
                state=row[at + 3 * n :],
            )
            for row in taken
        ], lost
