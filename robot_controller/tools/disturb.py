"""``robot-controller disturb --torque N·m [--duration s] [--joint NAME]``: push
the arm of a running graph with an external torque, as a hand or a bump
would, and watch the controller reject it.

Sends one ``/sim/disturbance`` message (``std_msgs/Float64MultiArray``
``[torque_nm…, duration_s]``: one torque per joint, then the duration;
layout dims ``torque_nm`` and ``duration_s``) to the simulator, which applies
it in the physics beside the actuator's torque for ``duration_s`` of its
time and reports what acts on ``/sim/disturbance_applied`` (both recorded).
The joints are the running simulator's (its ``/sim/joint_states`` names, if
heard within ``NAMES_TIMEOUT_S``), else the package's reference arm's.

A run's loop topics are in a DDS partition of its own (``ros.partition``): unless
``FASTRTPS_DEFAULT_PROFILES_FILE`` is set, this process takes the observer
profile, which hears every run and writes into every run's partition (so
every run on the domain gets the push) and into the default partition, where a
simulator started by hand listens.
"""

from __future__ import annotations

import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from robot_controller.ros import partition
from robot_controller.tools.hearing import wait_until_heard

TOPIC = "/sim/disturbance"
PROG = "robot-controller disturb"
NAMES_TIMEOUT_S = 2.0  #: how long to listen for the running simulator's joint names
MATCH_TIMEOUT_S = 10.0  #: how long to wait for the simulator's subscription
DELIVERY_TIMEOUT_S = 2.0
SIMULATOR_NODE = "simulator"
RANGE_ENV = "ROS_AUTOMATIC_DISCOVERY_RANGE"


def disturbance_data(torque_nm: np.ndarray, duration_s: float) -> list[float]:
    """The ``/sim/disturbance`` array: one torque per joint (N·m), then the duration (s)."""
    return [float(t) for t in torque_nm] + [float(duration_s)]


def torques_for(names: list[str], torque_nm: float, joint: str | None) -> np.ndarray | str:
    """``torque_nm`` on ``joint`` (zero on the others), or on every joint if None; or a reason."""
    if joint is None:
        return np.full(len(names), float(torque_nm))
    if joint not in names:
        return f"unknown joint {joint!r}: the arm's joints are {names}"
    return np.where(np.array(names) == joint, float(torque_nm), 0.0)


def _fail(message: str, code: int) -> int:
    print(f"{PROG}: {message}", file=sys.stderr)
    return code


def _isolation_env() -> tuple[dict[str, str | None], Path | None]:
    """Before this process's first DDS participant: the observer profile and
    localhost discovery, unless set already. Returns what to restore."""
    saved = {key: os.environ.get(key) for key in (partition.PROFILES_ENV, RANGE_ENV)}
    folder = None
    if not os.environ.get(partition.PROFILES_ENV):
        folder = Path(tempfile.mkdtemp(prefix="robot-controller-disturb-"))
        os.environ[partition.PROFILES_ENV] = str(partition.write_observer_profile(folder / "observer.xml"))
    if not os.environ.get(RANGE_ENV):
        os.environ[RANGE_ENV] = "LOCALHOST"
    return saved, folder


def _restore_env(saved: dict[str, str | None]) -> None:
    for key, value in saved.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value


def disturb(torque_nm: float, duration_s: float, joint: str | None, *, wait_s: float = MATCH_TIMEOUT_S) -> int:
    """Send one disturbance to the running simulator: ``torque_nm`` (N·m) on
    ``joint`` (zero on the others; every joint if None) for ``duration_s`` of
    the simulator's time. Returns 0 once sent, 1 if no simulator is listening,
    2 for a request the simulator would drop (unknown joint, bad numbers).
    ``wait_s``: how long to wait for the simulator to match."""
    from robot_controller.core.model.plant import MAX_DISTURBANCE_NM, check_disturbance

    if not (np.isfinite(torque_nm) and np.isfinite(duration_s)):
        return _fail(f"torque and duration must be finite numbers, got {torque_nm} N·m and {duration_s} s", 2)
    saved, folder = _isolation_env()
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray, MultiArrayDimension

    context = rclpy.Context()
    node = executor = None
    try:
        rclpy.init(context=context)
        node = Node("disturb", context=context, start_parameter_services=False)
    finally:
        # Fast DDS has read the profile with the first participant: leave the environment as it was.
        _restore_env(saved)
        if folder is not None:
            shutil.rmtree(folder, ignore_errors=True)
    try:
        domain = context.get_domain_id()
        qos = QoSProfile(
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.VOLATILE,
            history=HistoryPolicy.KEEP_LAST,
            depth=1,
        )
        heard: list[str] = []

        def on_state(msg: JointState) -> None:
            if not heard and len(msg.name) > 0:
                heard.extend(msg.name)

        subscription = node.create_subscription(JointState, "/sim/joint_states", on_state, qos)
        publisher = node.create_publisher(Float64MultiArray, TOPIC, qos)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        start = time.monotonic()
        while not heard and time.monotonic() - start < NAMES_TIMEOUT_S:
            executor.spin_once(timeout_sec=0.05)
        node.destroy_subscription(subscription)
        if heard:
            names, source = list(heard), "the running simulator's"
        else:
            from robot_controller import resources
            from robot_controller.core.model.plant import joint_names, load_model

            names, source = joint_names(load_model(resources.default_urdf())), "the reference arm's"
        torque = torques_for(names, torque_nm, joint)
        if isinstance(torque, str):
            return _fail(f"{torque} ({source})", 2)
        checked = check_disturbance(disturbance_data(torque, duration_s), len(names))
        if isinstance(checked, str):
            return _fail(checked, 2)
        if not wait_until_heard(node, publisher, TOPIC, SIMULATOR_NODE, since=start, wait_s=wait_s):
            return _fail(f"no simulator is listening on {TOPIC} (domain {domain})", 1)
        msg = Float64MultiArray()
        msg.layout.dim = [
            MultiArrayDimension(label="torque_nm", size=len(names), stride=len(names)),
            MultiArrayDimension(label="duration_s", size=1, stride=1),
        ]
        msg.data = disturbance_data(torque, duration_s)
        publisher.publish(msg)
        # Reliable: do not take the participant away before the readers have it.
        from rclpy.duration import Duration

        delivered = publisher.wait_for_all_acked(Duration(seconds=DELIVERY_TIMEOUT_S))
        where = (
            f"on {joint}"
            if joint is not None
            else "on " + (names[0] if len(names) == 1 else "each of " + ", ".join(names))
        )
        capped = (
            f" (the simulator caps it at {MAX_DISTURBANCE_NM:g} N·m)" if abs(torque_nm) > MAX_DISTURBANCE_NM else ""
        )
        print(
            f"{PROG}: sent {torque_nm:g} N·m {where} for {duration_s:g} s on {TOPIC} (domain {domain})"
            + capped
            + ("" if delivered else "; not acknowledged within 2 s")
        )
        return 0
    finally:
        if executor is not None:
            executor.shutdown(timeout_sec=1.0)
        node.destroy_node()
        rclpy.try_shutdown(context=context)
