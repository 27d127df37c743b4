"""``robot-controller estop [--release]``: the operator's button. Publishes the e-stop (port ``estop``,
``std_msgs/Bool``, true = stop) and calls the simulator's ``estop_button`` service (``blocks.spec``),
so the drive stops even if the topic were lost; latched until released. The level is sent
again for a while: a listener that matched late still hears it."""

from __future__ import annotations

import time

from rclpy.duration import Duration
from std_msgs.msg import Bool
from std_srvs.srv import SetBool

from robot_controller.blocks import spec
from robot_controller.ros.qos import LATCHED_QOS
from robot_controller.tools.graph import open_graph

# Latched: a node that starts after the stop still hears it (the nodes' readers are volatile: any writer matches).
PUBLISH_QOS = LATCHED_QOS
DISCOVERY_TIMEOUT_S = 5.0
SETTLE_S = 0.5
ACK_WAIT_S = 3.0
# Sent again for this long: a reader that matches the writer only after the first copy (discovery is two-sided, and
# slow on a busy host) is volatile and gets no history, yet must hear the stop. The nodes latch the level, so a copy
# is harmless.
RESEND_FOR_S = 1.5
RESEND_EVERY_S = 0.25


def _simulated(node) -> bool:
    """Whether a simulator hears the e-stop (its service answers too), not a robot's drive."""
    return any(info.node_name == "simulator" for info in node.get_subscriptions_info_by_topic(spec.ESTOP.topic))


def send(engage: bool, timeout_s: float = DISCOVERY_TIMEOUT_S) -> tuple[bool, str]:
    """Engage (or release) the e-stop. Returns (someone obeyed, a one-line report)."""
    with open_graph("estop") as graph:
        node = graph.node
        publisher = node.create_publisher(Bool, spec.ESTOP.topic, PUBLISH_QOS)
        client = node.create_client(SetBool, spec.ESTOP_SERVICE.service)
        # Every (volatile) listener must match before the one message goes out, and the service be up.
        deadline = time.monotonic() + timeout_s
        settled_since, last = time.monotonic(), -1
        while time.monotonic() < deadline:
            matched = publisher.get_subscription_count()
            if matched != last or matched < len(node.get_subscriptions_info_by_topic(spec.ESTOP.topic)):
                settled_since, last = time.monotonic(), matched
            elif (
                matched > 0
                and time.monotonic() - settled_since >= SETTLE_S
                and (
                    client.service_is_ready() or not _simulated(node)  # a robot's run has no simulator to answer
                )
            ):
                break
            time.sleep(0.05)
        listeners = sorted({info.node_name for info in node.get_subscriptions_info_by_topic(spec.ESTOP.topic)})
        publisher.publish(Bool(data=engage))
        service_note = "the simulator's service did not answer" if _simulated(node) else "no simulator (a robot)"
        if client.service_is_ready():
            future = client.call_async(SetBool.Request(data=engage))
            end = time.monotonic() + timeout_s
            while not future.done() and time.monotonic() < end:
                time.sleep(0.05)  # the graph's executor spins in its own thread
            if future.done() and future.result() is not None:
                service_note = f"simulator: {future.result().message}"
        resend_until = time.monotonic() + RESEND_FOR_S
        while time.monotonic() < resend_until:
            time.sleep(RESEND_EVERY_S)
            publisher.publish(Bool(data=engage))
        # Deliver before the node goes: every matched reader acknowledges.
        publisher.wait_for_all_acked(Duration(seconds=ACK_WAIT_S))
    what = "e-stop ENGAGED" if engage else "e-stop released"
    if not listeners and not service_note.startswith("simulator:"):
        return (
            False,
            f"{what}, but no node is listening on {spec.ESTOP.topic} (is the stack running on this ROS_DOMAIN_ID?)",
        )
    return True, f"{what}: heard by {', '.join(listeners) or f'no {spec.ESTOP.topic} subscriber'}; {service_note}"
