"""camera_node: the graph's camera, hosting the camera block (``blocks.camera``)."""

from __future__ import annotations

from typing import Any

from robot_controller.blocks import spec
from robot_controller.ros.adapter import BlockNode, Extras
from robot_controller.ros.process import run
from robot_controller.ros.qos import LATEST_QOS


class CameraExtras(Extras):
    """The camera hears every state in turn, or (``every_state`` false) only the latest: a camera that cannot keep
    up drops frames, as a real one does, rather than fall ever further behind the world."""

    def reader_qos(self, port: spec.Port) -> Any:
        if port is spec.TRUE_STATE and not self.node.params["every_state"]:
            return LATEST_QOS
        return super().reader_qos(port)


def CameraNode() -> BlockNode:  # noqa: N802 (made as a node class is, by ``ros.process.run``)
    return BlockNode("camera_node", CameraExtras)


def main(args: list[str] | None = None) -> int:
    return run(CameraNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
