"""The QoS classes of the stack's topics, and why each is what it is."""

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

# Reliable, volatile, keep-last: compatible with the tutorial's default-QoS
# publishers and subscribers, so its nodes talk to ours unchanged. Depth 1000
# (10 s of a 100 Hz topic, a few hundred kB) lets a reader that falls behind
# (the recorder, below the loop) catch up without losing samples.
CONTROL_QOS = QoSProfile(
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
    history=HistoryPolicy.KEEP_LAST,
    depth=1000,
)

# What a controller, a drive or an encoder acts on: the newest message only.
# A node that was paused must not work through a backlog of stale readings or
# torques when it resumes (and in lockstep there is one message in flight).
LATEST_QOS = QoSProfile(
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
    history=HistoryPolicy.KEEP_LAST,
    depth=1,
)
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
