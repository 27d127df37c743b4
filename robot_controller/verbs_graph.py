"""The verbs that talk to a running graph: the e-stop, a push, a move, a
trajectory file, and ros2cli's ``topic`` and ``param`` habits (``tools``).
"""

from __future__ import annotations

import sys
from pathlib import Path


def estop(*, release: bool) -> int:
    from robot_controller.ros import estop as estop_module

    heard, report = estop_module.send(engage=not release)
    print(f"robot-controller: {report}", file=sys.stdout if heard else sys.stderr)
    return 0 if heard else 1


def disturb(torque_nm: float, duration_s: float, joint: str | None) -> int:
    from robot_controller.tools.disturb import disturb as send

    return send(torque_nm, duration_s, joint)


def goto(positions: list[float], time_s: float | None, joints: list[str] | None) -> int:
    from robot_controller.tools.send_trajectory import goto as send

    return send(positions, time_s, joints)


def send_trajectory(path: Path) -> int:
    from robot_controller.tools.send_trajectory import send_file

    return send_file(path)


def topic(kind: str, *args, **kwargs) -> int:
    from robot_controller.tools import topic as topic_tool

    return {"list": topic_tool.topic_list, "echo": topic_tool.topic_echo, "hz": topic_tool.topic_hz}[kind](
        *args, **kwargs
    )


def param(kind: str, *args) -> int:
    from robot_controller.tools import param as param_tool

    return {
        "list": param_tool.param_list,
        "get": param_tool.param_get,
        "set": param_tool.param_set,
        "dump": param_tool.param_dump,
    }[kind](*args)
