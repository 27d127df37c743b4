"""A plain ROS client of the arm, as MoveIt or any control_msgs user is: none of our DDS profile, our partitions or
our code. It learns the joints from ``/joint_states``, reads ``/robot_description``, then sends
FollowJointTrajectory goals and prints one JSON object of what it got (tests/scenarios/test_follow_joint_trajectory.py).

Usage: ``python follow_joint_trajectory_client.py [--quick]`` on the run's ROS_DOMAIN_ID; ``--quick``: only the
3-point goal. Every target is an offset from where the arm is when the client starts (so it suits any arm whose
range has room for ±0.5 rad there). ``--judge [--freeze-pid PID] [--home Q,...] [--swing-s S]``: instead, how goals
are judged: one naming an unknown joint, a swing of 1.2 rad in ``S`` s (0.7) from ``home`` (default −0.6 rad on every
joint) cancelled at its peak speed, then (with ``--freeze-pid``) a goal during which that process (the controller) is
frozen from mid-motion until past its end."""

from __future__ import annotations

import json
import os
import signal
import sys
import time
import uuid

import numpy as np
import rclpy
from action_msgs.msg import GoalStatus
from builtin_interfaces.msg import Duration
from control_msgs.action import FollowJointTrajectory
from control_msgs.msg import JointTolerance
from rclpy.action import ActionClient
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from trajectory_msgs.msg import JointTrajectoryPoint

ACTION = "/joint_trajectory_controller/follow_joint_trajectory"
STATUS = {
    GoalStatus.STATUS_SUCCEEDED: "SUCCEEDED",
    GoalStatus.STATUS_CANCELED: "CANCELED",
    GoalStatus.STATUS_ABORTED: "ABORTED",
}


def duration(seconds: float) -> Duration:
    sec, nanosec = divmod(round(seconds * 1e9), 1_000_000_000)
    return Duration(sec=sec, nanosec=nanosec)


class Client:
    def __init__(self) -> None:
        self.node = rclpy.create_node(f"plain_client_{uuid.uuid4().hex[:6]}")
        self.action = ActionClient(self.node, FollowJointTrajectory, ACTION)
        self.states: list[tuple[float, list[str], list[float]]] = []  # (stamp s: the run's clock, names, positions)
        self.description: str | None = None
        # Depth 1: each reading taken is the latest, so a busy client's stamps do not lag behind a backlog.
        self.node.create_subscription(JointState, "/joint_states", self.joint_states, 1)
        latched = QoSProfile(
            depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
        )
        self.node.create_subscription(String, "/robot_description", self.robot_description, latched)

    def joint_states(self, msg: JointState) -> None:
        stamp_s = msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9
        self.states.append((stamp_s, list(msg.name), list(msg.position)))

    def stamp_s(self) -> float:
        """The run's time, as the latest /joint_states says (its stamps: sim time on a paced run): no later than now."""
        return self.states[-1][0]

    def fresh_stamp_s(self) -> float:
        """The stamp of a reading published after this call: no earlier than now (the second new one: the first may
        have been waiting in the reader's history)."""
        count = len(self.states)
        deadline = time.monotonic() + 5.0
        while len(self.states) < count + 2 and time.monotonic() < deadline:
            rclpy.spin_once(self.node, timeout_sec=0.01)
        return self.stamp_s()

    def robot_description(self, msg: String) -> None:
        self.description = msg.data

    def spin_for(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            rclpy.spin_once(self.node, timeout_sec=0.01)

    def spin_until(self, future, timeout_s: float):
        rclpy.spin_until_future_complete(self.node, future, timeout_sec=timeout_s)
        return future.result() if future.done() else None

    def position_now(self, samples: int = 10) -> np.ndarray:
        """The mean of the latest /joint_states (noisy readings)."""
        return np.mean([q for _, _, q in self.states[-samples:]], axis=0)

    def goal(self, names, points, *, path_tolerance=None, goal_tolerance=None, goal_time_s=0.0):
        goal = FollowJointTrajectory.Goal()
        goal.trajectory.joint_names = list(names)
        for time_s, positions in points:
            point = JointTrajectoryPoint(positions=[float(x) for x in positions])
            point.time_from_start = duration(time_s)
            goal.trajectory.points.append(point)
        if path_tolerance is not None:
            goal.path_tolerance = [JointTolerance(name=n, position=path_tolerance) for n in names]
        if goal_tolerance is not None:
            goal.goal_tolerance = [JointTolerance(name=n, position=goal_tolerance) for n in names]
        goal.goal_time_tolerance = duration(goal_time_s)
        return goal

    def send(self, goal):
        """The goal's handle (None if the server never answered) and the list its feedback goes into."""
        feedback: list = []
        handle = self.spin_until(
            self.action.send_goal_async(goal, feedback_callback=lambda m: feedback.append(m.feedback)), 15.0
        )
        return handle, feedback

    def result(self, handle, timeout_s: float = 30.0) -> dict:
        if handle is None:
            return {"status": "NO_ANSWER"}
        if not handle.accepted:
            return {"status": "REJECTED"}
        got = self.spin_until(handle.get_result_async(), timeout_s)
        if got is None:
            return {"status": "TIMEOUT"}
        return {
            "status": STATUS.get(got.status, str(got.status)),
            "error_code": got.result.error_code,
            "error_string": got.result.error_string,
            "stamp_s": self.fresh_stamp_s(),  # after the client heard it, on the run's clock
        }


def summary(feedback: list, joints: list[str]) -> dict:
    """What the goal's feedback said: how many, the joints it names, its largest position error."""
    whole = [f for f in feedback if len(f.error.positions) == len(joints)]
    errors = [float(np.max(np.abs(f.error.positions))) for f in whole]
    worst = whole[int(np.argmax(errors))] if whole else None
    return {
        "count": len(feedback),
        "joint_names": sorted({tuple(f.joint_names) for f in feedback}),
        "max_error_rad": max(errors) if errors else None,
        # Where it was largest: the feedback's stamp (the run's clock), its index, desired and actual.
        "worst": None
        if worst is None
        else {
            "stamp_s": worst.header.stamp.sec + worst.header.stamp.nanosec * 1e-9,
            "index": int(np.argmax(errors)),
            "desired": list(worst.desired.positions),
            "actual": list(worst.actual.positions),
        },
        "desired_last": list(feedback[-1].desired.positions) if feedback else None,
    }


#: The judged swing: this far (rad) in this long (s): a quintic's peak speed 1.875·1.2/0.7 = 3.2 rad/s, the default
#: sine's (π rad/s), reached half-way, when the cancel goes.
SWING_RAD, SWING_S = 1.2, 0.7
#: The frozen goal: its length, when the controller is frozen (s after it was accepted) and for how long.
FROZEN_GOAL_S, FREEZE_AT_S, FREEZE_FOR_S = 3.0, 1.0, 4.0


def judge(
    client: Client, joints: list[str], home: np.ndarray, freeze_pid: int | None, swing_s: float = SWING_S
) -> dict:
    """The goals that are judged: rejected, cancelled at speed (``swing_s``: the swing's time), and (``freeze_pid``)
    frozen under."""
    out: dict = {"home": home.tolist()}
    unknown, _ = client.send(client.goal(["no_such_joint"], [(1.0, [0.1])]))
    out["unknown_joint"] = client.result(unknown, 10.0)
    rest, _ = client.send(client.goal(joints, [(2.0, home)]))
    out["to_home"] = client.result(rest)
    client.spin_for(0.5)

    swing, _ = client.send(client.goal(joints, [(swing_s, home + SWING_RAD)]))
    client.spin_for(swing_s / 2)
    out["cancel_stamp_s"] = client.stamp_s()  # no later than the cancel: the latest reading heard
    cancel = client.spin_until(swing.cancel_goal_async(), 5.0) if swing is not None else None
    out["cancel_accepted"] = bool(cancel is not None and len(cancel.goals_canceling) == 1)
    out["canceled"] = client.result(swing, 10.0)
    client.spin_for(2.0)
    out["hold_until_stamp_s"] = client.stamp_s()
    if freeze_pid is None:
        return out

    frozen, _ = client.send(client.goal(joints, [(FROZEN_GOAL_S, home)]))
    client.spin_for(FREEZE_AT_S)
    os.kill(freeze_pid, signal.SIGSTOP)
    try:
        time.sleep(FREEZE_FOR_S)  # not spinning: nothing this client hears meanwhile matters
    finally:
        os.kill(freeze_pid, signal.SIGCONT)
    out["frozen"] = client.result(frozen, 20.0)
    out["frozen_target"] = home.tolist()
    client.spin_for(1.0)
    out["after_frozen"] = client.position_now().tolist()
    return out


def main() -> None:
    quick = "--quick" in sys.argv[1:]
    rclpy.init()
    client = Client()
    out: dict = {"server": client.action.wait_for_server(timeout_sec=60.0)}
    deadline = time.monotonic() + 30.0
    while (len(client.states) < 20 or client.description is None) and time.monotonic() < deadline:
        client.spin_for(0.1)
    out["joint_states_heard"] = len(client.states)
    # One arm on the domain: another run sharing ROS_DOMAIN_ID would add its publishers (and its own action server).
    out["joint_states_publishers"] = client.node.count_publishers("/joint_states")
    out["action_servers"] = client.node.count_publishers(f"{ACTION}/_action/feedback")
    out["robot_description_chars"] = len(client.description or "")
    if not out["server"] or len(client.states) < 20:
        print(json.dumps(out), flush=True)
        return
    joints = client.states[-1][1]
    out["joint_names"] = joints
    out["description_names_every_joint"] = all(f'name="{name}"' in (client.description or "") for name in joints)
    base = client.position_now()
    out["base"] = base.tolist()
    if "--judge" in sys.argv[1:]:
        default = ",".join([f"{-SWING_RAD / 2:g}"] * len(joints))
        home = np.array([float(x) for x in _option("--home", default).split(",")])
        freeze = _option("--freeze-pid", None)
        swing_s = float(_option("--swing-s", str(SWING_S)))
        out.update(judge(client, joints, home, None if freeze is None else int(freeze), swing_s))
        print(json.dumps(out), flush=True)
        return

    def at(offset: float) -> list[float]:
        return (base + offset).tolist()

    # A 3-point goal, reached within its goal tolerance.
    handle, feedback = client.send(
        client.goal(joints, [(1.5, at(0.1)), (3.0, at(0.2)), (4.0, at(0.15))], goal_tolerance=0.02, goal_time_s=1.0)
    )
    out["three_point"] = {**client.result(handle), "feedback": summary(feedback, joints)}
    client.spin_for(0.5)
    out["after_three_point"] = client.position_now().tolist()
    if quick:
        print(json.dumps(out), flush=True)
        return

    # Preemption: the first goal aborted by the second, which succeeds.
    first, _ = client.send(client.goal(joints, [(3.0, at(-0.1))]))
    client.spin_for(1.0)
    second, _ = client.send(client.goal(joints, [(2.0, at(0.1))]))
    out["preempted"] = client.result(first, 10.0)
    out["preempting"] = client.result(second)

    # Cancel one second into a move from +0.1 to +0.5: it stops and holds there.
    moving, _ = client.send(client.goal(joints, [(3.0, at(0.5))]))
    client.spin_for(1.0)
    cancel = client.spin_until(moving.cancel_goal_async(), 5.0) if moving is not None else None
    out["cancel_accepted"] = bool(cancel is not None and len(cancel.goals_canceling) == 1)
    out["canceled"] = client.result(moving, 10.0)
    client.spin_for(0.5)
    mark = len(client.states)
    client.spin_for(1.5)
    held = np.array([q for _, _, q in client.states[mark:]])
    out["hold"] = {
        "samples": len(held),
        "drift_rad": float(np.max(np.abs(held[-10:].mean(0) - held[:10].mean(0)))) if len(held) >= 20 else None,
        "position": held.mean(0).tolist() if len(held) else None,
        "from_stamp_s": client.states[mark][0] if len(held) else None,
        "until_stamp_s": client.stamp_s(),
    }

    # Refused at once: a joint the arm lacks; then a path tolerance no arm keeps.
    unknown, _ = client.send(client.goal(["no_such_joint"], [(1.0, [0.1])]))
    out["unknown_joint"] = client.result(unknown, 10.0)
    tight, _ = client.send(client.goal(joints, [(2.0, at(0.0))], path_tolerance=1e-6))
    out["tight_path_tolerance"] = client.result(tight, 10.0)
    print(json.dumps(out), flush=True)


def _option(name: str, default: str | None) -> str | None:
    args = sys.argv[1:]
    return args[args.index(name) + 1] if name in args else default


if __name__ == "__main__":
    try:
        main()
    finally:
        rclpy.try_shutdown()
