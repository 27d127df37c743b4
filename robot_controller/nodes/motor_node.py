"""motor_node: the graph's drive, hosting the drive block (``blocks.drive``)."""

from __future__ import annotations

from robot_controller.ros.adapter import BlockNode
from robot_controller.ros.process import run


def MotorNode() -> BlockNode:  # noqa: N802 (made as a node class is, by ``ros.process.run``)
    return BlockNode("motor_node")


def main(args: list[str] | None = None) -> int:
    return run(MotorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
