"""camera_node: the graph's camera, hosting the camera block (``blocks.camera``)."""

from __future__ import annotations

from robot_controller.ros.adapter import BlockNode
from robot_controller.ros.process import run


def CameraNode() -> BlockNode:  # noqa: N802 (made as a node class is, by ``ros.process.run``)
    return BlockNode("camera_node")


def main(args: list[str] | None = None) -> int:
    return run(CameraNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
