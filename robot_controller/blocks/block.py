"""What a block is: one part of the loop (planner, controller, drive, world, sensor) with no ROS in it. It declares
the ports it reads and writes (named in ``blocks.spec``), keeps its own state and is stepped with the values that
arrived, at a time its host's clock gives; it never reads its host's fields, and never asks which clock that is.
The same block runs in a ROS node (``ros.adapter``) and in process (``blocks.wiring``), made from the graph spec's
``BLOCKS`` by the name its node's ``block`` parameter gives."""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from typing import Any, Protocol

from robot_controller.blocks import spec


class Log(Protocol):
    """How a block speaks: its host decides where the lines go (a node's logger, a list)."""

    def info(self, message: str) -> None: ...

    def warn(self, key: str, message: str) -> None:
        """A warning, rate-limited per ``key`` by the host (a flood of bad messages says one line)."""

    def warning(self, message: str) -> None:
        """A warning said every time."""

    def error(self, message: str) -> None: ...


class Block(Protocol):
    #: the ports it reads, by ``blocks.spec`` name
    inputs: tuple[str, ...]
    #: the ports it writes
    outputs: tuple[str, ...]

    def start(self) -> dict[str, Any]:
        """What it writes once, before any step (a latched description)."""

    def step(self, t_s: float, inputs: Mapping[str, Any]) -> dict[str, Any]:
        """Take the values that arrived (port → value; empty when woken with none) at ``t_s`` s of the host's
        clock; return what it writes now (port → value)."""

    def wake_period_s(self) -> float | None:
        """How often it asks to be stepped with no input (a drive's timeout check); None: only on inputs."""

    def check_params(self, params: Mapping[str, Any]) -> None:
        """Raise ``ConfigError`` (its reason) if this combination of values cannot run."""

    def set_params(self, params: Mapping[str, Any], changed: set[str]) -> None:
        """Take new values (already checked) while running."""


def block_class(node_name: str, params: Mapping[str, Any]) -> type:
    """The class of the block ``node_name`` runs with ``params`` (its ``block``; the spec's first without one)."""
    choices = spec.BLOCKS[node_name]
    module, _, name = choices[params.get("block") or next(iter(choices))].partition(":")
    return getattr(importlib.import_module(module), name)


def make_block(node_name: str, params: Mapping[str, Any], log: Log, world_waits: bool) -> Block:
    """The block ``node_name`` runs; ``world_waits``: the loop's clock waits for each effort (the sim's clock)."""
    return block_class(node_name, params)(params, log, world_waits=world_waits)


class Lines:
    """A ``Log`` that keeps every line (in process; warnings once per key, or per line)."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self._warned: set[str] = set()

    def info(self, message: str) -> None:
        self.lines.append(message)

    def warn(self, key: str, message: str) -> None:
        if key not in self._warned:
            self._warned.add(key)
            self.lines.append(message)

    def warning(self, message: str) -> None:
        self.warn(message, message)

    error = warning
