"""``goto Q… [--time S] [--joints NAMES]`` and ``trajectory FILE.yaml``: send one ``JointTrajectory`` to the planner
(``/trajectory_planner/joint_trajectory``), which blends it from the reference in force or refuses it. The topic has no
answer: the tool waits ``ANSWER_TIMEOUT_S`` for the planner's ``/rosout`` line, exit 0 once taken, 2 if refused or
malformed, 1 if no planner listens or no answer came (a refusal is said at most once per 2 s)."""

from __future__ import annotations

import queue
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from robot_controller.tools import graph, trajectory_file
from robot_controller.tools.graph import ToolError
from robot_controller.tools.trajectory_file import TrajectoryFileError, TrajectorySpec

TOPIC = "/trajectory_planner/joint_trajectory"
PLANNER_NODE = "trajectory_planner"
STATE_TIMEOUT_S = 2.0  #: how long goto listens for the arm's /joint_states
MATCH_TIMEOUT_S = 10.0  #: how long to wait for the planner's subscription
ANSWER_TIMEOUT_S = 2.0  #: how long to listen on /rosout for the planner's verdict
TAKEN, REFUSED = "joint trajectory taken: ", "joint trajectory refused: "


def to_message(spec: TrajectorySpec) -> Any:
    """The ``JointTrajectory`` for ``spec`` (stamp 0: timed from its receipt)."""
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    msg = JointTrajectory(joint_names=list(spec.joint_names))
    for point in spec.points:
        ns = round(point.time_from_start_s * 1e9)
        at = Duration(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
        values = {"positions": point.positions, "velocities": point.velocities, "accelerations": point.accelerations}
        msg.points.append(JointTrajectoryPoint(**values, time_from_start=at))
    return msg


def _send(g: graph.Graph, spec: TrajectorySpec, prog: str, what: str, wait_s: float) -> int:
    from rcl_interfaces.msg import Log
    from trajectory_msgs.msg import JointTrajectory

    answers: queue.SimpleQueue = queue.SimpleQueue()

    def on_log(msg: Any) -> None:
        if msg.name == PLANNER_NODE and msg.msg.startswith((TAKEN, REFUSED)):
            answers.put(msg.msg)

    g.node.create_subscription(Log, "/rosout", on_log, graph.reliable_qos(100))  # volatile: no earlier lines
    publisher = g.node.create_publisher(JointTrajectory, TOPIC, graph.reliable_qos(100))
    delivered = g.send(publisher, TOPIC, to_message(spec), PLANNER_NODE, wait_s=wait_s)
    sent = f"sent {what} on {TOPIC} (domain {g.domain})"
    try:
        answer = answers.get(timeout=ANSWER_TIMEOUT_S)
    except queue.Empty:
        unacked = "" if delivered else ", not acknowledged"
        raise ToolError(
            f"{sent}{unacked}, but no answer from the planner on /rosout within {ANSWER_TIMEOUT_S:g} s: taken or "
            "refused is unknown (it says why it refuses at most once per 2 s); see the planner's log"
        ) from None
    if answer.startswith(REFUSED):
        raise ToolError(f"the planner refused it: {answer[len(REFUSED) :]}", 2)
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
        state = g.first_joint_state("/joint_states", STATE_TIMEOUT_S) if joints is None or time_s is None else None
        if joints is not None:
            names = list(joints)
        else:
            names = list(state.name) if state is not None else graph.reference_arm_joints()
        if time_s is None:
            time_s = trajectory_file.GOTO_UNKNOWN_S
            at = {} if state is None else dict(zip(state.name, state.position, strict=False))
            speed = {} if state is None else dict(zip(state.name, state.velocity, strict=False))
            if len(positions) == len(names) and all(name in at for name in names):
                distance = max(abs(q - at[name]) for q, name in zip(positions, names, strict=True))
                time_s = trajectory_file.goto_time_s(distance, max(abs(speed.get(name, 0.0)) for name in names))
        try:
            spec = trajectory_file.goto(positions, names, time_s)
        except TrajectoryFileError as exc:
            raise ToolError(str(exc), 2) from None
        target = ", ".join(f"{name} {q:g}" for name, q in zip(names, spec.points[0].positions, strict=True))
        return _send(g, spec, "goto", f"{target} rad in {time_s:.3g} s", wait_s)


@graph.command("trajectory")
def send_file(path: Path, *, wait_s: float = MATCH_TIMEOUT_S) -> int:
    """Send the joint trajectory in the YAML file at ``path``."""
    try:
        spec = trajectory_file.load(path)
    except TrajectoryFileError as exc:
        raise ToolError(str(exc), 2) from None
    with graph.open_graph("trajectory") as g:
        what = f"{len(spec.points)} point(s) over {spec.duration_s:.3g} s"
        return _send(g, spec, "trajectory", what, wait_s)
