"""The QoS classes of the stack's topics, and why each is what it is."""

import os

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from robot_controller.ros.partition import LOOP_QOS_ENV


def _keep_last(depth: int, *, reliable: bool = True, latched: bool = False) -> QoSProfile:
    reliability = ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT
    durability = DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE
    return QoSProfile(reliability=reliability, durability=durability, history=HistoryPolicy.KEEP_LAST, depth=depth)


# Reliable, volatile, keep-last: compatible with the tutorial's default-QoS publishers and subscribers. Depth 1000 (10 s
# of a 100 Hz topic) lets a reader that falls behind (the recorder, below the loop) catch up without losing samples.
CONTROL_QOS = _keep_last(1000)
# What a controller, a drive or an encoder acts on: the newest message only, never a stale backlog after a pause.
LATEST_QOS = _keep_last(1)
# The same, best effort: across a lossy link a lost sample is not waited for (the next one made it stale).
LATEST_BEST_EFFORT_QOS = _keep_last(1, reliable=False)
# Sim time: every message is a tick's, taken in order (the planner sends each a tick early: two may be in flight).
SIM_TIME_QOS = _keep_last(100)
# Sim time's readings (the sensor's writer, our controller's reader): transient local as well, since it has more
# readers than the controller (the planner's action feedback, any ROS client's): one of them can open the sensor's gate
# (ros.publishing) before the controller matched, and a tick's reading lost so stalls the run for good. A controller
# that matches late gets the reading outstanding. A volatile reader (the tutorial's controller) matches it all the same.
# The writer keeps CONTROL_QOS's 1000, which a recorder that falls behind catches up from.
SIM_TIME_READINGS_QOS = _keep_last(1000, latched=True)
SIM_TIME_READINGS_READER_QOS = _keep_last(100, latched=True)
# A state, not an event (the brake request): a late reader, such as a respawned simulator, gets it at once.
LATCHED_QOS = _keep_last(1, latched=True)
# The sim's clock: a reader that matches late still gets the latest tick.
CLOCK_QOS = _keep_last(1000, latched=True)
# The e-stop: volatile readers, so `ros2 topic pub` on it matches; the nodes that obey it latch it, not DDS.
ESTOP_QOS = LATEST_QOS
# A camera's frames (0.9 MB each): the newest few on the wall clock; where the world waits, every one (each is a tick's
# reading to be), which the world's waiting keeps to a few in flight.
FRAMES_QOS = _keep_last(3)
SIM_TIME_FRAMES_QOS = _keep_last(10)
# An observer (the viewer): best effort, short queues; no writer waits for it or resends to it.
OBSERVER_QOS = _keep_last(50, reliable=False)


def loop_qos(world_waits: bool) -> QoSProfile:
    """A periodic loop topic's reader: reliable (a lost message would stall a sim-time run), keeping every
    message where the world waits, best effort on the wall clock when the launcher split the loop across hosts."""
    if world_waits:
        return SIM_TIME_QOS
    if os.environ.get(LOOP_QOS_ENV) == "best_effort":
        return LATEST_BEST_EFFORT_QOS
    return LATEST_QOS


def profile(qos_class: str, *, world_waits: bool) -> QoSProfile:
    """The profile of a port's QoS class (``blocks.spec.QOS_CLASSES``) in this clock mode."""
    profiles = {
        "control": CONTROL_QOS,
        "latest": LATEST_QOS,
        "loop": loop_qos(world_waits),
        "readings": SIM_TIME_READINGS_READER_QOS if world_waits else loop_qos(False),
        "readings_writer": SIM_TIME_READINGS_QOS if world_waits else CONTROL_QOS,
        "latched": LATCHED_QOS,
        "clock": CLOCK_QOS,
        "frames": SIM_TIME_FRAMES_QOS if world_waits else FRAMES_QOS,
    }
    return profiles[qos_class]
