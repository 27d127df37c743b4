"""The verbs that talk to a running graph (``tools``): the e-stop, a push, a move, a trajectory file,
and ros2cli's ``topic`` and ``param`` habits."""

from __future__ import annotations

import argparse
import re
import sys
from pathlib import Path

from robot_controller.blocks import spec
from robot_controller.cli.args import Parser, joint_list, positive_int, positive_seconds, verb
from robot_controller.tools import disturb, param, send_trajectory, topic  # no ROS until a verb runs


def register(sub) -> None:
    p = verb(sub, "estop", "emergency stop of the running graph: torque off, brakes on, latched", _estop)
    p.add_argument("--release", action="store_true", help="release the e-stop; the loop re-acquires")
    disturb_help = f"push the running arm: an external torque for a while ({spec.DISTURBANCE.topic})"
    p = verb(sub, "disturb", disturb_help, lambda a: disturb.disturb(a.torque, a.duration, a.joint))
    p.add_argument("--torque", type=float, required=True, help="N·m")
    p.add_argument("--duration", type=positive_seconds, default=0.5, help="s (default 0.5)")
    p.add_argument("--joint", help="joint name (default: every joint)")
    goto_help = (
        "move the running arm to joint positions, at rest after --time: a FollowJointTrajectory goal, its result "
        "awaited (exit 0 succeeded; 2 refused, aborted or canceled; 1 unknown; Ctrl-C cancels it)"
    )
    p = verb(
        sub, "goto", goto_help, lambda a: send_trajectory.goto(a.positions, a.time, a.joints, controller=a.controller)
    )
    p.add_argument("positions", type=float, nargs="+", metavar="Q", help="rad, one per joint")
    p.add_argument("--time", type=positive_seconds, help="s to get there (default: from the distance, at least 1)")
    p.add_argument(
        "--joints", type=joint_list, help="names of the positions' joints, comma-separated (default: the arm's)"
    )
    _trajectory_controller_option(p)
    file_help = (
        "follow a joint trajectory from a YAML file (joint_names, points): a FollowJointTrajectory goal, its result "
        "awaited (exit codes as goto's; Ctrl-C cancels it)"
    )
    p = verb(sub, "trajectory", file_help, lambda a: send_trajectory.send_file(a.file, controller=a.controller))
    p.add_argument("file", type=Path, help="YAML: joint_names: [...], points: [{time_from_start, positions}, ...]")
    _trajectory_controller_option(p)
    topics = sub.add_parser("topic", help="ros2 topic's habits: list, echo, hz").add_subparsers(
        dest="topic_verb", required=True, parser_class=Parser
    )
    p = verb(topics, "list", "the graph's topics", lambda a: topic.topic_list(show_types=a.show_types))
    p.add_argument("-t", "--show-types", action="store_true")
    p = verb(topics, "echo", "print a topic's messages", lambda a: topic.topic_echo(a.topic, count=a.count, csv=a.csv))
    p.add_argument("topic")
    p.add_argument("--count", type=positive_int, help="stop after this many messages")
    p.add_argument(
        "--csv",
        action="store_true",
        help="a header line naming the columns, then one line of comma-separated values per message",
    )
    p = verb(topics, "hz", "a topic's rate", lambda a: topic.topic_hz(a.topic, window=a.window, duration_s=a.duration))
    p.add_argument("topic")
    p.add_argument("--window", "-w", type=positive_int, default=10_000, help="messages the statistics cover")
    p.add_argument("--duration", type=positive_seconds, help="stop after this long, s (default: Ctrl-C)")
    params = sub.add_parser("param", help="ros2 param's habits: list, get, set, dump").add_subparsers(
        dest="param_verb", required=True, parser_class=Parser
    )
    p = verb(params, "list", "a node's parameters", lambda a: param.param_list(a.node))
    p.add_argument("node")
    p = verb(params, "get", "one parameter's value", lambda a: param.param_get(a.node, a.name))
    for name in ("node", "name"):
        p.add_argument(name)
    set_help = "set one parameter (the node refuses a bad value with its reason)"
    p = verb(params, "set", set_help, lambda a: param.param_set(a.node, a.name, a.value))
    for name in ("node", "name", "value"):
        p.add_argument(name)
    p = verb(params, "dump", "a node's parameters as a ROS 2 parameter file", lambda a: param.param_dump(a.node))
    p.add_argument("node")


# The planner's controller_name's form (a ROS name segment), checked before any ROS is loaded.
_CONTROLLER_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


def _controller_name(text: str) -> str:
    if not _CONTROLLER_NAME.fullmatch(text):
        raise argparse.ArgumentTypeError(f"a letter, then letters, digits or '_' (a ROS name), got {text!r}")
    return text


def _trajectory_controller_option(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--controller",
        type=_controller_name,
        default=send_trajectory.CONTROLLER,
        metavar="NAME",
        help=f"the planner's controller_name: the goal goes to {spec.FOLLOW_JOINT_TRAJECTORY.action_for('NAME')}",
    )


def _estop(a: argparse.Namespace) -> int:
    from robot_controller.ros import estop

    heard, report = estop.send(engage=not a.release)
    print(f"robot-controller: {report}", file=sys.stdout if heard else sys.stderr)
    return 0 if heard else 1
