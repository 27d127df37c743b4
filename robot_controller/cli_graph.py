"""``robot-controller``'s verbs that talk to a running graph: estop, disturb,
goto, trajectory, and ros2cli's ``topic`` and ``param`` habits."""

from __future__ import annotations

from pathlib import Path

from robot_controller import verbs_graph
from robot_controller.cli_options import Parser, joint_list, positive_int, positive_seconds, verb


def graph_verbs(sub) -> None:
    p = verb(
        sub,
        "estop",
        "emergency stop of the running graph: torque off, brakes on, latched",
        lambda a: verbs_graph.estop(release=a.release),
    )
    p.add_argument("--release", action="store_true", help="release the e-stop; the loop re-acquires")
    p = verb(
        sub,
        "disturb",
        "push the running arm: an external torque for a while (/sim/disturbance)",
        lambda a: verbs_graph.disturb(a.torque, a.duration, a.joint),
    )
    p.add_argument("--torque", type=float, required=True, help="N·m")
    p.add_argument("--duration", type=positive_seconds, default=0.5, help="s (default 0.5)")
    p.add_argument("--joint", help="joint name (default: every joint)")
    p = verb(
        sub,
        "goto",
        "move the running arm to joint positions, at rest after --time (a JointTrajectory to the planner)",
        lambda a: verbs_graph.goto(a.positions, a.time, a.joints),
    )
    p.add_argument("positions", type=float, nargs="+", metavar="Q", help="rad, one per joint")
    p.add_argument("--time", type=positive_seconds, help="s to get there (default: from the distance, at least 1)")
    p.add_argument(
        "--joints", type=joint_list, help="names of the positions' joints, comma-separated (default: the arm's)"
    )
    p = verb(
        sub,
        "trajectory",
        "send a joint trajectory from a YAML file to the running planner (joint_names, points)",
        lambda a: verbs_graph.send_trajectory(a.file),
    )
    p.add_argument("file", type=Path, help="YAML: joint_names: [...], points: [{time_from_start, positions}, ...]")
    topic = sub.add_parser("topic", help="ros2 topic's habits: list, echo, hz")
    topics = topic.add_subparsers(dest="topic_verb", required=True, parser_class=Parser)
    p = verb(topics, "list", "the graph's topics", lambda a: verbs_graph.topic("list", show_types=a.show_types))
    p.add_argument("-t", "--show-types", action="store_true")
    p = verb(
        topics,
        "echo",
        "print a topic's messages",
        lambda a: verbs_graph.topic("echo", a.topic, count=a.count, csv=a.csv),
    )
    p.add_argument("topic")
    p.add_argument("--count", type=positive_int, help="stop after this many messages")
    p.add_argument("--csv", action="store_true", help="one line of comma-separated values per message")
    p = verb(
        topics,
        "hz",
        "a topic's rate",
        lambda a: verbs_graph.topic("hz", a.topic, window=a.window, duration_s=a.duration),
    )
    p.add_argument("topic")
    p.add_argument("--window", "-w", type=positive_int, default=10_000, help="messages the statistics cover")
    p.add_argument("--duration", type=positive_seconds, help="stop after this long, s (default: Ctrl-C)")
    param = sub.add_parser("param", help="ros2 param's habits: list, get, set, dump")
    params = param.add_subparsers(dest="param_verb", required=True, parser_class=Parser)
    p = verb(params, "list", "a node's parameters", lambda a: verbs_graph.param("list", a.node))
    p.add_argument("node")
    p = verb(params, "get", "one parameter's value", lambda a: verbs_graph.param("get", a.node, a.name))
    p.add_argument("node")
    p.add_argument("name")
    p = verb(
        params,
        "set",
        "set one parameter (the node refuses a bad value with its reason)",
        lambda a: verbs_graph.param("set", a.node, a.name, a.value),
    )
    p.add_argument("node")
    p.add_argument("name")
    p.add_argument("value")
    p = verb(
        params, "dump", "a node's parameters as a ROS 2 parameter file", lambda a: verbs_graph.param("dump", a.node)
    )
    p.add_argument("node")
