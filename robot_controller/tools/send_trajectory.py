"""``goto`` and ``trajectory``: one ``JointTrajectory`` as a ``FollowJointTrajectory`` goal to the planner's action
server (as ros2_controllers' JointTrajectoryController serves it), its result awaited (its duration plus
``RESULT_MARGIN_S``) and said in one line: exit 0 once it succeeded, 2 if rejected, aborted (JTC's error code and the
reason) or canceled by another client, 1 if no server answered or no result came (what is unknown is said). A
rejected goal's reason is the planner's log line for it, heard on the log topic (the action's answer carries none).
Ctrl-C while waiting cancels the goal: the arm stops and holds; the cancel's outcome is said, exit 130."""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from robot_controller.blocks import spec as graph_spec
from robot_controller.core.reference import tolerances
from robot_controller.tools import graph, trajectory_file
from robot_controller.tools.graph import ToolError
from robot_controller.tools.trajectory_file import TrajectoryFileError, TrajectorySpec

#: The planner parameter ``controller_name``'s default, which names the action.
CONTROLLER = "joint_trajectory_controller"
STATE_TIMEOUT_S = 2.0  #: how long goto listens for the arm's readings
MATCH_TIMEOUT_S = 10.0  #: how long to wait for the action server
ANSWER_TIMEOUT_S = 5.0  #: how long the server may take to accept a goal, or to answer a cancel
#: How long past the trajectory's end the result may come: the planner's goal_time_tolerance_s (1 s by default), a
#: stop first when joining directly would swing past the first point, a busy host.
RESULT_MARGIN_S = 1.0 + 4.0
STOP_TIMEOUT_S = 5.0  #: how long a canceled goal may take to stop (at stop_deceleration) and end
REASON_TIMEOUT_S = 1.0  #: how long to wait for the planner's log line saying why a goal was rejected
INTERRUPTED = 130  # Ctrl-C: the goal canceled, or its fate unknown

#: control_msgs/FollowJointTrajectory's result codes by value.
ERROR_CODE_NAMES = {
    getattr(tolerances, name): name
    for name in "SUCCESSFUL INVALID_GOAL INVALID_JOINTS OLD_HEADER_TIMESTAMP PATH_TOLERANCE_VIOLATED "
    "GOAL_TOLERANCE_VIOLATED".split()
}


def action_name(controller: str) -> str:
    """The FollowJointTrajectory action of the planner's ``controller_name``."""
    return graph_spec.FOLLOW_JOINT_TRAJECTORY.action_for(controller.strip("/"))


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


def verdict(status: int, error_code: int, error_string: str) -> tuple[str, int]:
    """A goal's end (its ``GoalStatus`` status) in words, and the exit code: 0 succeeded, 2 aborted or canceled, 1
    any other status."""
    from action_msgs.msg import GoalStatus

    reason = error_string or "no reason given"
    if status == GoalStatus.STATUS_SUCCEEDED and error_code == tolerances.SUCCESSFUL:
        return f"SUCCEEDED ({reason})", 0
    code = f"{ERROR_CODE_NAMES.get(error_code, 'error code')} ({error_code})"
    if status == GoalStatus.STATUS_ABORTED:
        return f"ABORTED, {code}: {reason}", 2
    if status == GoalStatus.STATUS_CANCELED:
        return f"CANCELED ({reason})", 2
    return f"ended with status {status}, {code}: {reason}", 1


def _wait(future: Any, timeout_s: float) -> Any | None:
    """The future's result once done within ``timeout_s`` (the graph's thread spins), else None."""
    deadline = time.monotonic() + timeout_s
    while not future.done():
        if time.monotonic() >= deadline:
            return None
        time.sleep(graph.POLL_S)
    return future.result()


def _wait_for_server(g: graph.Graph, client: Any, name: str, controller: str, what: str, wait_s: float) -> None:
    """Return once the server has been ready for ``graph.MATCH_SETTLE_S`` (discovery is two-sided and staggered: an
    answer sent before the server matched our reader would be lost), else ``ToolError``."""
    since = time.monotonic()
    ready_since = None
    while True:
        now = time.monotonic()
        if not client.server_is_ready():
            ready_since = None
        elif ready_since is None:
            ready_since = now
        elif now - ready_since >= graph.MATCH_SETTLE_S:
            return
        if now - since > wait_s and ready_since is None:
            raise ToolError(
                f"{what}: no {name} action server on domain {g.domain} within {wait_s:g} s, the goal was not sent "
                f"(is the planner running, its controller_name {controller}?)"
            )
        time.sleep(0.05)


def _follow(g: graph.Graph, spec: TrajectorySpec, prog: str, what: str, controller: str, wait_s: float) -> int:
    from control_msgs.action import FollowJointTrajectory
    from rclpy.action import ActionClient
    from rclpy.logging import LoggingSeverity

    name = action_name(controller)
    client = ActionClient(g.node, FollowJointTrajectory, name)
    rejections = _hear_rejections(g)
    # Its warnings are of a duplicate response DDS delivered late (seen on a busy host after a cancel): not the user's.
    g.node.get_logger().get_child("action_client").set_level(LoggingSeverity.ERROR)
    try:
        _wait_for_server(g, client, name, controller, what, wait_s)
    except KeyboardInterrupt:
        raise ToolError(f"{what}: interrupted before the goal was sent", INTERRUPTED) from None
    sent = client.send_goal_async(FollowJointTrajectory.Goal(trajectory=to_message(spec)))
    result = None
    try:
        handle = _wait(sent, ANSWER_TIMEOUT_S)
        if handle is None:
            raise ToolError(
                f"{what}: sent to {name} (domain {g.domain}), no answer within {ANSWER_TIMEOUT_S:g} s: whether it "
                "was accepted, and is moving the arm, is unknown"
            )
        if not handle.accepted:
            reason = _wait_for(rejections, REASON_TIMEOUT_S)
            said = f": {reason}" if reason is not None else " (its reason is in the planner's log)"
            raise ToolError(f"{what}: REJECTED by {name}{said}", 2)
        result = handle.get_result_async()
        wait_result_s = spec.duration_s + RESULT_MARGIN_S
        response = _wait(result, wait_result_s)
    except KeyboardInterrupt:
        raise ToolError(f"{what}: interrupted: {_cancel(sent, result)}", INTERRUPTED) from None
    if response is None:
        raise ToolError(
            f"{what}: accepted by {name}, but no result within {wait_result_s:.3g} s: whether it succeeded is "
            "unknown (it may still be in force)"
        )
    said, code = verdict(response.status, response.result.error_code, response.result.error_string)
    if code != 0:
        raise ToolError(f"{what}: {said}", code)
    print(f"robot-controller {prog}: {what}: {said}", flush=True)
    return 0


def _hear_rejections(g: graph.Graph) -> list[str]:
    """The list the planner's logged reasons for rejecting a goal go into, heard from now (matched before the goal is
    sent: waiting for the server takes longer than discovery)."""
    from rcl_interfaces.msg import Log

    reasons: list[str] = []

    def heard(msg: Any) -> None:
        if msg.name.endswith("trajectory_planner") and msg.msg.startswith(tolerances.GOAL_REJECTED_LOG):
            reasons.append(msg.msg[len(tolerances.GOAL_REJECTED_LOG) :])

    g.node.create_subscription(Log, graph_spec.ROSOUT.topic, heard, graph.qos(100))
    return reasons


def _wait_for(reasons: list[str], timeout_s: float) -> str | None:
    """The latest reason heard within ``timeout_s`` (the spinning thread fills the list), else None."""
    deadline = time.monotonic() + timeout_s
    while not reasons and time.monotonic() < deadline:
        time.sleep(graph.POLL_S)
    return reasons[-1] if reasons else None


def _cancel(sent: Any, result: Any | None) -> str:
    """Cancel the goal ``sent`` (once its acceptance is heard) and say how it ended (a second Ctrl-C ends the tool
    without a word)."""
    from action_msgs.srv import CancelGoal

    handle = sent.result() if sent.done() else _wait(sent, ANSWER_TIMEOUT_S)
    if handle is None:
        return f"no answer to the goal within {ANSWER_TIMEOUT_S:g} s: whether it is in force is unknown"
    if not handle.accepted:
        return "the goal was rejected (nothing to cancel)"
    if result is None:
        result = handle.get_result_async()
    answer = _wait(handle.cancel_goal_async(), ANSWER_TIMEOUT_S)
    if answer is None:
        asked = f"cancel sent, no answer within {ANSWER_TIMEOUT_S:g} s"
    elif answer.return_code == CancelGoal.Response.ERROR_NONE:
        asked = "cancel accepted"
    else:
        refusals = {
            CancelGoal.Response.ERROR_REJECTED: "rejected",
            CancelGoal.Response.ERROR_UNKNOWN_GOAL_ID: "refused: unknown goal",
            CancelGoal.Response.ERROR_GOAL_TERMINATED: "refused: the goal had ended",
        }
        asked = f"cancel {refusals.get(answer.return_code, f'refused (code {answer.return_code})')}"
    response = _wait(result, STOP_TIMEOUT_S)
    if response is None:
        return f"{asked}; no result within {STOP_TIMEOUT_S:g} s: whether the arm stopped is unknown"
    return f"{asked}; {verdict(response.status, response.result.error_code, response.result.error_string)[0]}"


@graph.command("goto", interrupted=INTERRUPTED)
def goto(
    positions: Sequence[float],
    time_s: float | None = None,
    joints: Sequence[str] | None = None,
    *,
    controller: str = CONTROLLER,
    wait_s: float = MATCH_TIMEOUT_S,
) -> int:
    """Move the running arm's joints to ``positions`` (rad), at rest after ``time_s`` (None: a safe default), as a
    goal to ``controller``'s FollowJointTrajectory action; wait for its result."""
    with graph.open_graph("goto") as g:
        names, state = list(joints or []), None
        if joints is None or time_s is None:
            heard, state = g.arm_joints(graph_spec.READING.topic, STATE_TIMEOUT_S)
            names = names or heard
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
        return _follow(g, spec, "goto", f"{target} rad in {time_s:.3g} s", controller, wait_s)


@graph.command("trajectory", interrupted=INTERRUPTED)
def send_file(path: Path, *, controller: str = CONTROLLER, wait_s: float = MATCH_TIMEOUT_S) -> int:
    """Follow the joint trajectory in the YAML file at ``path`` as a goal to ``controller``'s action; wait for its
    result."""
    try:
        spec = trajectory_file.load(path)
    except TrajectoryFileError as exc:
        raise ToolError(str(exc), 2) from None
    with graph.open_graph("trajectory") as g:
        what = f"{len(spec.points)} point(s) over {spec.duration_s:.3g} s"
        return _follow(g, spec, "trajectory", what, controller, wait_s)
