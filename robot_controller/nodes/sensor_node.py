"""sensor_node: the graph's sensor, hosting the sensor block its ``block`` parameter names (the encoder,
``blocks.encoder``, by default)."""

from __future__ import annotations

from robot_controller.ros.adapter import BlockNode
from robot_controller.ros.process import run


def SensorNode() -> BlockNode:  # noqa: N802 (made as a node class is, by ``ros.process.run``)
    return BlockNode("sensor_node")


def main(args: list[str] | None = None) -> int:
    return run(SensorNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
