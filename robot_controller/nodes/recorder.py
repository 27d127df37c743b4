"""A rosbag2 recorder in Python: subscribes to the loop's topics without
deserialising (raw CDR) and writes them to an MCAP bag with rosbags, the way
``ros2 bag record`` would, so Foxglove, PlotJuggler and ``ros2 bag`` open it.
"""
from __future__ import annotations

import threading
from pathlib import Path

from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from robot_controller.nodes.base import CONTROL_QOS

# Reliable with a deep queue: the recorder runs at normal priority beside
# real-time nodes and may be late, but must not lose what it is late for.
RECORDER_QOS = QoSProfile(reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.VOLATILE,
                          history=HistoryPolicy.KEEP_LAST, depth=1000)

# topic → (ROS message class, rosbag2 type name)
TOPICS = {
    "/trajectory": (Float64MultiArray, "std_msgs/msg/Float64MultiArray"),
    "/joint_states": (JointState, "sensor_msgs/msg/JointState"),
    "/joint_commands": (Float64MultiArray, "std_msgs/msg/Float64MultiArray"),
    "/sim/effort": (Float64MultiArray, "std_msgs/msg/Float64MultiArray"),
    "/sim/joint_states": (JointState, "sensor_msgs/msg/JointState"),
    "/controller/state": (Float64MultiArray, "std_msgs/msg/Float64MultiArray"),
}
TELEMETRY_TOPICS = {
    "/diagnostics": (DiagnosticArray, "diagnostic_msgs/msg/DiagnosticArray"),
    "/motor/command_latency": (Float64MultiArray, "std_msgs/msg/Float64MultiArray"),
}
CLOCK_TOPIC = {"/clock": (Clock, "rosgraph_msgs/msg/Clock")}


class BagRecorder:
    """Records ``topics`` into ``bag_dir`` (MCAP) while spinning in a thread.

    A context manager: entering starts recording, leaving stops the node and
    closes the bag. ``counts`` and ``first_receipt_ns`` tell the caller what
    has arrived.
    """

    def __init__(self, context, bag_dir: Path, *, sim_time: bool = False) -> None:
        self.bag_dir = Path(bag_dir)
        self.topics = {**TOPICS, **TELEMETRY_TOPICS, **(CLOCK_TOPIC if sim_time else {})}
        self.node = Node("recorder", context=context, start_parameter_services=False,
                         parameter_overrides=[Parameter("use_sim_time", Parameter.Type.BOOL, sim_time)])
        self.clock_s = 0.0  #: latest /clock (sim time), s
        if sim_time:
            self.node.create_subscription(Clock, "/clock", self._clock_callback, CONTROL_QOS)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.node)
        self.writer = Writer(self.bag_dir, version=9, storage_plugin=StoragePlugin.MCAP)
        self.counts = {topic: 0 for topic in self.topics}
        self.first_receipt_ns: dict[str, int] = {}
        self.event = threading.Event()  # set on every message: lets waiters poll cheaply
        self._thread: threading.Thread | None = None
        self._lock = threading.Lock()
        self._open = False

    def __enter__(self) -> BagRecorder:
        self.writer.open()
        self._open = True
        typestore = get_typestore(Stores.ROS2_JAZZY)
        for topic, (msg_class, type_name) in self.topics.items():
            connection = self.writer.add_connection(topic, type_name, typestore=typestore)
            self.node.create_subscription(msg_class, topic, self._callback(topic, connection), RECORDER_QOS,
                                          raw=True)
        self._thread = threading.Thread(target=self._spin, name="recorder", daemon=True)
        self._thread.start()
        return self

    def _clock_callback(self, msg: Clock) -> None:
        self.clock_s = msg.clock.sec + msg.clock.nanosec * 1e-9

    def _spin(self) -> None:
        try:
            self.executor.spin()
        except Exception:  # noqa: BLE001 - context shut down under us at the end
            pass

    def _callback(self, topic: str, connection):
        clock = self.node.get_clock()

        def record(data: bytes) -> None:
            stamp = clock.now().nanoseconds
            with self._lock:
                if not self._open:
                    return
                self.writer.write(connection, stamp, data)
            self.counts[topic] += 1
            self.first_receipt_ns.setdefault(topic, stamp)
            self.event.set()

        return record

    def __exit__(self, *exc_info) -> None:
        self.executor.shutdown(timeout_sec=2.0)
        with self._lock:
            self._open = False
            self.writer.close()
        self.node.destroy_node()
