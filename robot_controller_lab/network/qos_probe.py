"""What a reader's QoS makes of a lossy link: one 100 Hz topic across the
bench's two namespaces, measured at the reader.

A publisher in the control host sends ``[sequence, send_time_s, padding…]``
at 100 Hz with the stack's publisher QoS (reliable, keep last 1000: the
recorder needs every sample); a reader in the robot host takes it with the
QoS under test, as a node acts on it (keep last ``depth``, newest first), and
notes each message's age on arrival (both hosts share this machine's clock).
Under loss: the fraction delivered, the age of what is delivered (p50, p99,
max), and the gaps a loop's watchdog would see (the longest interval without
a new message, intervals over 50 ms, the controller's ``watchdog_periods``).

``python -m robot_controller_lab.network.qos_probe`` runs the table (root); the
publisher and reader are this module's ``pub`` and ``sub`` modes.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

PERIOD_S = 0.01
MODULE = "robot_controller_lab.network.qos_probe"
TOPIC = "/qos_probe"
WATCHDOG_S = 0.05
LOSSES = (0, 5, 20)
READERS = (("reliable", 1), ("best_effort", 1), ("reliable", 10))


def probe_profile(path: Path, peer: str, base: Path) -> Path:
    """The stack's Fast DDS profile (``base``: its 50 ms heartbeat) over UDPv4 only (no shared memory between the
    namespaces: they share /dev/shm), discovering the other host by its address (an initial peer)."""
    import xml.etree.ElementTree as ET

    ns = "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"
    ET.register_namespace("", ns)
    tree = ET.parse(base)
    root = tree.getroot()
    q = f"{{{ns}}}"
    descriptors = ET.Element(f"{q}transport_descriptors")
    descriptor = ET.SubElement(descriptors, f"{q}transport_descriptor")
    ET.SubElement(descriptor, f"{q}transport_id").text = "udp_only"
    ET.SubElement(descriptor, f"{q}type").text = "UDPv4"
    root.insert(0, descriptors)
    rtps = root.find(f"{q}participant/{q}rtps")
    user = ET.SubElement(rtps, f"{q}userTransports")
    ET.SubElement(user, f"{q}transport_id").text = "udp_only"
    ET.SubElement(rtps, f"{q}useBuiltinTransports").text = "false"
    builtin = rtps.find(f"{q}builtin")
    peers = ET.SubElement(builtin, f"{q}initialPeersList")
    udp = ET.SubElement(ET.SubElement(peers, f"{q}locator"), f"{q}udpv4")
    ET.SubElement(udp, f"{q}address").text = peer
    tree.write(path, xml_declaration=True, encoding="UTF-8")
    return path


def probe_env(profile: Path) -> dict[str, str]:
    env = dict(os.environ)
    env.update(
        {
            "FASTRTPS_DEFAULT_PROFILES_FILE": str(profile),
            "RMW_IMPLEMENTATION": "rmw_fastrtps_cpp",
            "RMW_FASTRTPS_PUBLICATION_MODE": "SYNCHRONOUS",
            "ROS_DOMAIN_ID": "0",
        }
    )
    for name in ("ROS_STATIC_PEERS", "ROS_AUTOMATIC_DISCOVERY_RANGE", "ROS_LOCALHOST_ONLY"):
        env.pop(name, None)
    return env


def _qos(reliability: str, depth: int):
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(
        reliability=ReliabilityPolicy.RELIABLE if reliability == "reliable" else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.VOLATILE,
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
    )


def _spin(node, until: float) -> None:
    import rclpy

    while time.time() < until and rclpy.ok():
        rclpy.spin_once(node, timeout_sec=0.002)


def publish(duration_s: float, payload: int) -> None:
    import rclpy
    from std_msgs.msg import Float64MultiArray

    from robot_controller.ros.qos import CONTROL_QOS

    rclpy.init()
    node = rclpy.create_node("qos_probe_pub")
    pub = node.create_publisher(Float64MultiArray, TOPIC, CONTROL_QOS)
    deadline = time.time() + 30.0
    while pub.get_subscription_count() == 0 and time.time() < deadline:
        _spin(node, time.time() + 0.05)
    _spin(node, time.time() + 0.5)
    msg = Float64MultiArray()
    start = time.monotonic()
    for k in range(int(duration_s / PERIOD_S)):
        next_at = start + k * PERIOD_S
        delay = next_at - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        msg.data = [float(k), time.time()] + [0.0] * payload
        pub.publish(msg)
    _spin(node, time.time() + 1.0)
    rclpy.shutdown()


def subscribe(duration_s: float, reliability: str, depth: int, out: Path) -> None:
    import rclpy
    from std_msgs.msg import Float64MultiArray

    rows: list[tuple[float, float, float]] = []
    rclpy.init()
    node = rclpy.create_node("qos_probe_sub")
    node.create_subscription(
        Float64MultiArray, TOPIC, lambda m: rows.append((m.data[0], m.data[1], time.time())), _qos(reliability, depth)
    )
    end = time.time() + duration_s
    _spin(node, end)
    out.write_text(json.dumps(rows))
    rclpy.shutdown()


def figures(rows: list[list[float]], skip_s: float = 1.0) -> dict[str, float]:
    """Delivered fraction, age of what arrived and the gaps between arrivals, from ``skip_s`` after the first."""
    if not rows:
        return {"delivered": 0.0}
    data = np.asarray(rows, dtype=float)
    data = data[data[:, 2] >= data[0, 2] + skip_s]
    seq, sent, got = data[:, 0], data[:, 1], data[:, 2]
    if len(seq) < 2:
        return {"delivered": 0.0}
    age_ms = (got - sent) * 1e3
    gaps = np.diff(got)
    span = seq.max() - seq.min() + 1
    return {
        "delivered": float(len(np.unique(seq)) / span),
        "age_p50_ms": float(np.percentile(age_ms, 50)),
        "age_p99_ms": float(np.percentile(age_ms, 99)),
        "age_max_ms": float(age_ms.max()),
        "longest_gap_ms": float(gaps.max() * 1e3),
        "gaps_over_watchdog_per_min": float(np.sum(gaps > WATCHDOG_S) / (got[-1] - got[0]) * 60.0),
        "out_of_order": int(np.sum(np.diff(seq) < 0)),
    }


def measure(duration_s: float = 20.0, payload: int = 10) -> list[dict]:
    from robot_controller import resources
    from robot_controller_lab.network import netns

    base = resources.fastdds_profiles()
    results = []
    with netns.link() as net, tempfile.TemporaryDirectory() as tmp:
        robot_env = probe_env(probe_profile(Path(tmp) / "robot.xml", net.control.address, base))
        control_env = probe_env(probe_profile(Path(tmp) / "control.xml", net.robot.address, base))
        for loss in LOSSES:
            net.set_loss(loss)
            for reliability, depth in READERS:
                out = Path(tmp) / "rows.json"
                sub = net.spawn(
                    net.robot,
                    [sys.executable, "-m", MODULE, "sub", "--duration", str(duration_s + 4)]
                    + ["--reliability", reliability, "--depth", str(depth), "--out", str(out)],
                    env=robot_env,
                )
                pub = net.spawn(
                    net.control,
                    [sys.executable, "-m", MODULE, "pub", "--duration", str(duration_s), "--payload", str(payload)],
                    env=control_env,
                )
                pub.wait()
                sub.wait()
                rows = json.loads(out.read_text()) if out.exists() else []
                out.unlink(missing_ok=True)
                entry = {"loss_pct": loss, "reliability": reliability, "depth": depth} | figures(rows)
                print(json.dumps(entry), flush=True)
                results.append(entry)
    return results


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="qos_probe", description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=("table", "pub", "sub"), nargs="?", default="table")
    parser.add_argument("--duration", type=float, default=20.0)
    parser.add_argument("--payload", type=int, default=10)
    parser.add_argument("--reliability", default="reliable")
    parser.add_argument("--depth", type=int, default=1)
    parser.add_argument("--out", type=Path)
    args = parser.parse_args(argv)
    if args.mode == "pub":
        publish(args.duration, args.payload)
    elif args.mode == "sub":
        subscribe(args.duration, args.reliability, args.depth, args.out)
    else:
        measure(args.duration, args.payload)
    return 0


if __name__ == "__main__":
    sys.exit(main())
