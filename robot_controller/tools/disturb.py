"""``robot-controller disturb --torque N·m [--duration s] [--joint NAME]``: push a running arm with an external torque:
one disturbance (port ``disturbance``, ``[torque_nm…, duration_s]``), applied beside the actuator's for ``duration_s``
of sim time and reported as the disturbance applied. Joints: the running simulator's (its true state), else the
reference arm's."""

from __future__ import annotations

import numpy as np

from robot_controller.blocks import spec
from robot_controller.tools import graph
from robot_controller.tools.graph import ToolError

TOPIC = spec.DISTURBANCE.topic
NAMES_TIMEOUT_S = 2.0  #: how long to listen for the running simulator's joint names
MATCH_TIMEOUT_S = 10.0  #: how long to wait for the simulator's subscription
SIMULATOR_NODE = "simulator"
INTERRUPTED = 130  # Ctrl-C: the push may or may not have been sent


def disturbance_data(torque_nm: np.ndarray, duration_s: float) -> list[float]:
    """The disturbance's array: one torque per joint (N·m), then the duration (s)."""
    return [float(t) for t in torque_nm] + [float(duration_s)]


def torques_for(names: list[str], torque_nm: float, joint: str | None) -> np.ndarray | str:
    """``torque_nm`` on ``joint`` (zero on the others), or on every joint if None; or a reason."""
    if joint is None:
        return np.full(len(names), float(torque_nm))
    if joint not in names:
        return f"unknown joint {joint!r}: the arm's joints are {names}"
    return np.where(np.array(names) == joint, float(torque_nm), 0.0)


@graph.command("disturb", interrupted=INTERRUPTED)
def disturb(torque_nm: float, duration_s: float, joint: str | None, *, wait_s: float = MATCH_TIMEOUT_S) -> int:
    """Send ``torque_nm`` on ``joint`` (every joint if None) for ``duration_s`` of sim time to the running simulator,
    waiting up to ``wait_s`` for it to match: exit 0 once sent, 1 if none listens, 2 for a request it would drop."""
    from robot_controller.core.model import MAX_DISTURBANCE_NM, check_disturbance

    if not (np.isfinite(torque_nm) and np.isfinite(duration_s)):
        raise ToolError(f"torque and duration must be finite numbers, got {torque_nm} N·m and {duration_s} s", 2)
    with graph.open_graph("disturb") as g:
        from std_msgs.msg import Float64MultiArray, MultiArrayDimension

        publisher = g.node.create_publisher(Float64MultiArray, TOPIC, graph.qos(1))
        names, state = g.arm_joints(spec.TRUE_STATE.topic, NAMES_TIMEOUT_S)
        source = "the running simulator's" if state is not None else "the reference arm's"
        torque = torques_for(names, torque_nm, joint)
        if isinstance(torque, str):
            raise ToolError(f"{torque} ({source})", 2)
        checked = check_disturbance(disturbance_data(torque, duration_s), len(names))
        if isinstance(checked, str):
            raise ToolError(checked, 2)
        msg = Float64MultiArray(data=disturbance_data(torque, duration_s))
        msg.layout.dim = [
            MultiArrayDimension(label="torque_nm", size=len(names), stride=len(names)),
            MultiArrayDimension(label="duration_s", size=1, stride=1),
        ]
        delivered = g.send(publisher, TOPIC, msg, SIMULATOR_NODE, wait_s=wait_s)
        domain = g.domain
    where = joint if joint is not None else names[0] if len(names) == 1 else "each of " + ", ".join(names)
    capped = f" (the simulator caps it at {MAX_DISTURBANCE_NM:g} N·m)" if abs(torque_nm) > MAX_DISTURBANCE_NM else ""
    unacked = "" if delivered else f"; not acknowledged within {graph.DELIVERY_TIMEOUT_S:g} s"
    print(
        f"robot-controller disturb: sent {torque_nm:g} N·m on {where} for {duration_s:g} s on {TOPIC} "
        f"(domain {domain}){capped}{unacked}",
        flush=True,
    )
    return 0
