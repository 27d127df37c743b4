"""viewer: the live view of a run (``run --view``) in a browser, from a process of its own: an observer listening best
effort with short queues (a slow viewer loses samples, holds no one up), feeding rerun (``robot_controller.view``).
``python -m robot_controller.nodes.viewer --rrd DIR/view.rrd --port 9090 [--urdf FILE] [--control-rate HZ]``"""

from __future__ import annotations

import argparse
import sys
import time
import uuid
from pathlib import Path

import numpy as np
import rclpy
from rosbags.typesys import Stores, get_typestore

from robot_controller.blocks import spec
from robot_controller.core.controller import state_layout
from robot_controller.ros import scheduling
from robot_controller.ros.messages import stamp_to_s
from robot_controller.ros.process import make_executor, own_context
from robot_controller.ros.publishing import VIEWER_NODE
from robot_controller.ros.qos import OBSERVER_QOS

FLUSH_PERIOD_S = 0.1  # the browser's arm moves 10 times a second...
SERIES_PERIOD_S = 0.2  # ...and its plots 5 times (each send costs CPU, per entity)
FILE_PERIOD_S = 2.0  # view.rrd is written in chunks of 2 s
READY_PREFIX = "live view at "
TYPESTORE = get_typestore(Stores.ROS2_JAZZY)  # the raw CDR read as the bag reader reads it


def decode(data: bytes, msgtype: str):
    """A message from its raw CDR bytes (``sensor_msgs/msg/JointState``…), or None if they are not one."""
    try:
        return TYPESTORE.deserialize_cdr(data, msgtype)
    except Exception:  # noqa: BLE001 - any bytes that are not the type: dropped, as scoring skips them
        return None


class Viewer:
    """Subscriptions that feed a ``ViewFeed``."""

    def __init__(self, context, joint_names: list[str]) -> None:
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.node import Node
        from sensor_msgs.msg import CompressedImage, JointState
        from std_msgs.msg import Float64MultiArray

        self.feed = None  #: set before the first spin
        self.joints = list(joint_names)
        self.n = len(self.joints)
        self.node = Node(VIEWER_NODE, context=context, start_parameter_services=False)
        self.qos = OBSERVER_QOS
        self.order: list[int] | None = None  #: indices of the stack's joints in the JointState names
        self.node.create_subscription(Float64MultiArray, spec.STATE.topic, self._state, self.qos, raw=True)
        self.node.create_subscription(DiagnosticArray, spec.DIAGNOSTICS.topic, self._diagnostics, self.qos)
        self.node.create_subscription(
            Float64MultiArray, spec.COMMAND_RECEIPTS.topic, self._receipts, self.qos, raw=True
        )
        self.node.create_subscription(JointState, spec.TRUE_STATE.topic, self._true, self.qos, raw=True)
        self.node.create_subscription(JointState, spec.READING.topic, self._measured, self.qos, raw=True)
        self.node.create_subscription(Float64MultiArray, spec.REFERENCE.topic, self._planned, self.qos, raw=True)
        self.node.create_subscription(CompressedImage, spec.DETECTIONS.topic, self._detections, self.qos, raw=True)

    # The callbacks take raw CDR (rosbags decodes it faster than rclpy; unreadable: dropped).

    def _joint_state(self, data: bytes):
        msg = decode(data, "sensor_msgs/msg/JointState")
        if msg is None:
            return None
        stamp, names, position, effort = stamp_to_s(msg.header.stamp), msg.name, msg.position, msg.effort
        if self.order is None and names:
            try:
                self.order = [names.index(j) for j in self.joints]
            except ValueError:
                return None
        if self.order is not None and len(position) == len(names):
            index = self.order
        elif len(position) == self.n:
            index = list(range(self.n))
        else:
            return None
        return stamp, position[index], effort[index] if len(effort) == len(position) else np.full(self.n, np.nan)

    def _true(self, data: bytes) -> None:
        state = self._joint_state(data)
        if state is not None:
            self.feed.true_state(*state)

    def _measured(self, data: bytes) -> None:
        state = self._joint_state(data)
        if state is not None:
            self.feed.measured(state[0], state[1])

    @staticmethod
    def _array(data: bytes) -> np.ndarray | None:
        msg = decode(data, "std_msgs/msg/Float64MultiArray")
        return None if msg is None else msg.data

    def _state(self, data: bytes) -> None:
        values = self._array(data)
        values = None if values is None else state_layout.standard(values, self.n)  # a law's extra terms: not drawn
        if values is not None:
            self.feed.controller_state(values)

    def _planned(self, data: bytes) -> None:
        values, n = self._array(data), self.n
        if values is None:
            return
        if len(values) == 3 * n + 1:  # [q…, q̇…, q̈…, time_s]
            self.feed.planned(values[-1], values[:n])
        elif len(values) == 2 * n:  # the tutorial's [q, q̇]: no time of its own
            self.feed.planned(time.time(), values[:n])

    def _receipts(self, data: bytes) -> None:
        values = self._array(data)
        if values is not None:
            self.feed.receipts(values)

    def _detections(self, data: bytes) -> None:
        msg = decode(data, "sensor_msgs/msg/CompressedImage")
        if msg is not None:
            self.feed.detections(stamp_to_s(msg.header.stamp), msg.data.tobytes(), msg.format)

    def _diagnostics(self, msg) -> None:
        for status in msg.status:
            for kv in status.values:
                if kv.key == "jitter_p99_ms":
                    try:
                        self.feed.diagnostics(stamp_to_s(msg.header.stamp), float(kv.value))
                    except ValueError:
                        pass


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="viewer")
    parser.add_argument("--rrd", type=Path, required=True, help="where the view is saved for replay")
    parser.add_argument("--port", type=int, default=9090, help="serve the view at http://127.0.0.1:PORT")
    parser.add_argument("--urdf", default="", help="the arm's URDF (default: the package's reference arm)")
    parser.add_argument("--control-rate", type=float, default=100.0, help="the controller's rate, Hz")
    args = parser.parse_args(None if argv is None else argv[1:])  # argv[0] is the program, as for rclpy
    # The observers' nice value (and its scheduling group's), before any thread starts: threads inherit it.
    scheduling.apply_in_child(scheduling.Placement(nice=scheduling.OBSERVER_NICE))
    context, stop = own_context()

    from robot_controller import resources
    from robot_controller.view import layout
    from robot_controller.view import serve as serving
    from robot_controller.view.arm import Arm
    from robot_controller.view.feed import Outlet, ViewFeed

    arm = Arm(resources.resolve_urdf(args.urdf))
    # Listening first (what arrives waits in the readers' short queues), then rerun and its servers.
    viewer = Viewer(context, arm.joint_names)
    # One recording, two streams: to the browser every flush, to the file in larger chunks.
    recording_id = str(uuid.uuid4())
    live, saved = serving.open_recording(recording_id), serving.open_recording(recording_id)
    uri = serving.set_sinks(live, rrd=None, serve=True, blueprint=layout.blueprint(arm, live=True), newest_first=True)
    # The file gets few chunks (FILE_PERIOD_S): its footer (a line per chunk, held until the end) stays small.
    serving.set_sinks(saved, rrd=args.rrd, serve=False, blueprint=layout.blueprint(arm, live=True))
    for rec in (live, saved):
        layout.log_styles(rec, arm.joint_names, arm.units)
        layout.log_scene(rec, arm)
    web = serving.serve_web(uri, args.port)
    said = f"{serving.page_url(args.port)} (the page and its data on this one port; saved to {args.rrd})"
    print(READY_PREFIX + said, flush=True)

    outlets = [Outlet(live, SERIES_PERIOD_S, FLUSH_PERIOD_S), Outlet(saved, FILE_PERIOD_S)]
    viewer.feed = feed = ViewFeed(outlets, arm, nominal_period_s=1.0 / args.control_rate, live=True)
    executor = make_executor(context)
    executor.add_node(viewer.node)
    next_flush = time.monotonic()
    try:
        while not stop.is_set():
            executor.spin_once(timeout_sec=FLUSH_PERIOD_S)
            now = time.monotonic()
            if now >= next_flush:
                next_flush = max(next_flush + FLUSH_PERIOD_S, now)
                feed.flush(now)
    finally:
        executor.shutdown(timeout_sec=1.0)
        viewer.node.destroy_node()
        rclpy.try_shutdown(context=context)
        feed.flush(time.monotonic(), final=True)
        web.shutdown()
        for rec in (saved, live):
            rec.flush()
            rec.disconnect()
    return 0


if __name__ == "__main__":
    sys.exit(main())
