"""The QoS classes of the stack's topics, and why each is what it is."""

import os

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from robot_controller.ros.partition import LOOP_QOS_ENV


def _reliable_keep_last(depth: int) -> QoSProfile:
    return QoSProfile(
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.VOLATILE,
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
    )


# Reliable, volatile, keep-last: compatible with the tutorial's default-QoS
# publishers and subscribers, so its nodes talk to ours unchanged. Depth 1000
# (10 s of a 100 Hz topic, a few hundred kB) lets a reader that falls behind
# (the recorder, below the loop) catch up without losing samples.
CONTROL_QOS = _reliable_keep_last(1000)

# What a controller, a drive or an encoder acts on: the newest message only.
# A node that was paused must not work through a backlog of stale readings or
# torques when it resumes (lockstep readers use LOCKSTEP_QOS below).
LATEST_QOS = _reliable_keep_last(1)

# The same, best effort: across a lossy link a lost sample is not waited for (the next one
# has already made it stale). A reliable writer serves a best-effort reader.
LATEST_BEST_EFFORT_QOS = QoSProfile(
    reliability=ReliabilityPolicy.BEST_EFFORT,
    durability=DurabilityPolicy.VOLATILE,
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
)


# Lockstep: every message is a tick's and is taken in order, none is stale. The planner sends
# each sample a tick early, so two can be in flight to the controller: all are kept.
LOCKSTEP_QOS = _reliable_keep_last(100)


def loop_qos(lockstep: bool) -> QoSProfile:
    """The QoS of a periodic loop topic's reader (readings, references, commands, efforts):
    reliable on one host and in lockstep (a lost message would stall the run), keeping
    every message in lockstep, and best effort on the wall clock when the launcher split
    the loop across hosts."""
    if lockstep:
        return LOCKSTEP_QOS
    if os.environ.get(LOOP_QOS_ENV) == "best_effort":
        return LATEST_BEST_EFFORT_QOS
    return LATEST_QOS


# A state, not an event (the motor's brake request): a reader that starts late,
# such as a respawned simulator, gets the current value at once.
LATCHED_QOS = QoSProfile(
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
)
# /clock in lockstep: a reader that matches late (the controller pairs each
# reading with its tick's /clock, reading it with LATCHED_QOS) still gets the latest tick.
CLOCK_QOS = QoSProfile(
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
    history=HistoryPolicy.KEEP_LAST,
    depth=1000,
)
# /estop: volatile readers, so a plain `ros2 topic pub /estop` (volatile) matches too;
# the e-stop is latched by the nodes that obey it, not by DDS.
ESTOP_QOS = LATEST_QOS
