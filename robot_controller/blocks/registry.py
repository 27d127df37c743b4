"""The block a node runs, made from the graph spec's ``BLOCKS`` by the name its ``block`` parameter gives."""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any

from robot_controller.blocks import spec
from robot_controller.blocks.block import Block, Log


def block_class(node_name: str, params: Mapping[str, Any]) -> type:
    """The class of the block ``node_name`` runs with ``params`` (its ``block``; the spec's first without one)."""
    choices = spec.BLOCKS[node_name]
    path = choices[params.get("block") or next(iter(choices))]
    module, _, name = path.partition(":")
    return getattr(importlib.import_module(module), name)


def make(node_name: str, params: Mapping[str, Any], log: Log, world_waits: bool) -> Block:
    """The block ``node_name`` runs; ``world_waits``: the loop's clock waits for each effort (the sim's clock)."""
    return block_class(node_name, params)(params, log, world_waits=world_waits)
