"""``robot-controller goto Q… [--time S] [--joints NAMES]`` and ``robot-controller
trajectory FILE.yaml``: send one ``trajectory_msgs/JointTrajectory`` to the
running planner (``/trajectory_planner/joint_trajectory``, as
JointTrajectoryController's topic), which blends it from the reference in
force, or refuses it and goes on as it was.

``goto`` moves every joint to the positions given (rad, in the order of
``--joints``, else of the arm's ``/joint_states``), arriving at rest after
``--time`` s; by default after the farthest joint's distance at
``GOTO_SPEED`` (and at least ``GOTO_MIN_S``), or ``GOTO_UNKNOWN_S`` when the
arm's state is not heard. ``trajectory`` sends a YAML file
(``tools.trajectory_file``). The header stamp is 0: the planner counts
``time_from_start`` from when it takes the message.

The topic carries no answer (JTC's topic has none either), so the tool
listens on ``/rosout`` for the planner's one line about it for
``ANSWER_TIMEOUT_S`` and reports it: exit 0 once the planner took it, 2 if
it refused it or the request is malformed (one line with the reason), 1 if
no planner is listening or no answer was heard (the planner says why it
refuses at most once per 2 s, so a second refusal soon after another is
silent: the outcome is then unknown, and said so). Like ``disturb``, it speaks
through the observer profile (``tools.graph``), into every run's partition.
"""

from __future__ import annotations

import queue
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from robot_controller.tools import graph, hearing
from robot_controller.tools.graph import ToolError
from robot_controller.tools.trajectory_file import (
    GOTO_UNKNOWN_S,
    TrajectoryFileError,
    TrajectorySpec,
    goto_time_s,
    load,
)
from robot_controller.tools.trajectory_file import goto as goto_spec

TOPIC = "/trajectory_planner/joint_trajectory"
PLANNER_NODE = "trajectory_planner"
STATE_TIMEOUT_S = 2.0  #: how long goto listens for the arm's /joint_states
MATCH_TIMEOUT_S = 10.0  #: how long to wait for the planner's subscription
DELIVERY_TIMEOUT_S = 2.0
ANSWER_TIMEOUT_S = 2.0  #: how long to listen on /rosout for the planner's verdict
TAKEN, REFUSED = "joint trajectory taken: ", "joint trajectory refused: "


def _fail(prog: str, message: str, code: int = 2) -> int:
    print(f"robot-controller {prog}: {message}", file=sys.stderr, flush=True)
    return code


def to_message(spec: TrajectorySpec) -> Any:
    """The ``JointTrajectory`` for ``spec`` (stamp 0: timed from its receipt)."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    msg = JointTrajectory(joint_names=list(spec.joint_names))
    for point in spec.points:
        ns = round(point.time_from_start_s * 1e9)
        msg.points.append(
            JointTrajectoryPoint(
                positions=point.positions,
                velocities=point.velocities,
                accelerations=point.accelerations,
                time_from_start=Duration(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000),
            )
        )
    return msg


def _arm_state(g: graph.Graph) -> Any | None:
    """The first named ``/joint_states`` heard within ``STATE_TIMEOUT_S``, or None."""
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import JointState

    heard: queue.SimpleQueue = queue.SimpleQueue()
    subscription = g.node.create_subscription(
        JointState, "/joint_states", lambda msg: heard.put(msg) if msg.name else None, qos_profile_sensor_data
    )
    try:
        return heard.get(timeout=STATE_TIMEOUT_S)
    except queue.Empty:
        return None
    finally:
        g.node.destroy_subscription(subscription)


def _send(g: graph.Graph, spec: TrajectorySpec, prog: str, what: str, wait_s: float) -> int:
    from rcl_interfaces.msg import Log
    from rclpy.duration import Duration
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from trajectory_msgs.msg import JointTrajectory

    answers: queue.SimpleQueue = queue.SimpleQueue()

    def on_log(msg: Any) -> None:
        if msg.name == PLANNER_NODE and msg.msg.startswith((TAKEN, REFUSED)):
            answers.put(msg.msg)

    reliable = QoSProfile(
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.VOLATILE,
        history=HistoryPolicy.KEEP_LAST,
        depth=100,
    )
    g.node.create_subscription(Log, "/rosout", on_log, reliable)  # volatile: no earlier lines
    publisher = g.node.create_publisher(JointTrajectory, TOPIC, reliable)
    if not hearing.wait_until_heard(g.node, publisher, TOPIC, PLANNER_NODE, since=time.monotonic(), wait_s=wait_s):
        raise ToolError(f"no trajectory planner is listening on {TOPIC} (domain {g.domain})")
    publisher.publish(to_message(spec))
    delivered = publisher.wait_for_all_acked(Duration(seconds=DELIVERY_TIMEOUT_S))
    sent = f"sent {what} on {TOPIC} (domain {g.domain})"
    try:
        answer = answers.get(timeout=ANSWER_TIMEOUT_S)
    except queue.Empty:
        unacked = "" if delivered else ", not acknowledged"
        return _fail(
            prog,
            f"{sent}{unacked}, but no answer from the planner on /rosout within {ANSWER_TIMEOUT_S:g} s: taken or "
            "refused is unknown (it says why it refuses at most once per 2 s); see the planner's log",
            code=1,
        )
    if answer.startswith(REFUSED):
        return _fail(prog, f"the planner refused it: {answer[len(REFUSED) :]}")
    print(f"robot-controller {prog}: {sent}; the planner took it: {answer[len(TAKEN) :]}", flush=True)
    return 0


@graph.command("goto")
def goto(
    positions: Sequence[float],
    time_s: float | None = None,
    joints: Sequence[str] | None = None,
    *,
    wait_s: float = MATCH_TIMEOUT_S,
) -> int:
    """Move the running arm's joints to ``positions`` (rad), at rest after ``time_s`` (None: a safe default)."""
    with graph.open_graph("goto") as g:
        state = _arm_state(g) if joints is None or time_s is None else None
        if joints is not None:
            names = list(joints)
        elif state is not None:
            names = list(state.name)
        else:
            from robot_controller import resources
            from robot_controller.core.model.plant import joint_names, load_model

            names = joint_names(load_model(resources.default_urdf()))  # the reference arm's, as disturb
        if time_s is None:
            time_s = GOTO_UNKNOWN_S
            at = {} if state is None else dict(zip(state.name, state.position, strict=False))
            speed = {} if state is None else dict(zip(state.name, state.velocity, strict=False))
            if len(positions) == len(names) and all(name in at for name in names):
                distance = max(abs(q - at[name]) for q, name in zip(positions, names, strict=True))
                time_s = goto_time_s(distance, max(abs(speed.get(name, 0.0)) for name in names))
        try:
            spec = goto_spec(positions, names, time_s)
        except TrajectoryFileError as exc:
            return _fail("goto", str(exc))
        target = ", ".join(f"{name} {q:g}" for name, q in zip(names, spec.points[0].positions, strict=True))
        return _send(g, spec, "goto", f"{target} rad in {time_s:.3g} s", wait_s)


@graph.command("trajectory")
def send_file(path: Path, *, wait_s: float = MATCH_TIMEOUT_S) -> int:
    """Send the joint trajectory in the YAML file at ``path``."""
    try:
        spec = load(path)
    except TrajectoryFileError as exc:
        return _fail("trajectory", str(exc))
    with graph.open_graph("trajectory") as g:
        what = f"{len(spec.points)} point(s) over {spec.duration_s:.3g} s"
        return _send(g, spec, "trajectory", what, wait_s)
