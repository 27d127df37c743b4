"""vision_node: the graph's vision, hosting the vision block (``blocks.vision``)."""

from __future__ import annotations

from robot_controller.ros.adapter import BlockNode
from robot_controller.ros.process import run


def VisionNode() -> BlockNode:  # noqa: N802 (made as a node class is, by ``ros.process.run``)
    return BlockNode("vision_node")


def main(args: list[str] | None = None) -> int:
    return run(VisionNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
