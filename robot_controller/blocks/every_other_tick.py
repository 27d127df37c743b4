"""A sensor that reports every other sample of the encoder's (a bus that drops half the frames): the second sensor
block, chosen by ``sensor_node``'s ``block: every_other_tick``. The controller's estimator bridges the gaps."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from robot_controller.blocks.block import Log
from robot_controller.blocks.encoder import Encoder


class EveryOtherTick:
    inputs = Encoder.inputs
    outputs = Encoder.outputs

    def __init__(self, params: Mapping[str, Any], log: Log, *, world_waits: bool = False) -> None:
        self.encoder = Encoder(params, log, world_waits=world_waits)
        self.dropped = True  #: the last sample was dropped: the next is reported (the first is)

    def start(self) -> dict[str, Any]:
        return self.encoder.start()

    def wake_period_s(self) -> float | None:
        return self.encoder.wake_period_s()

    def check_params(self, params: Mapping[str, Any]) -> None:
        self.encoder.check_params(params)

    def set_params(self, params: Mapping[str, Any], changed: set[str]) -> None:
        self.encoder.set_params(params, changed)

    def step(self, t_s: float, inputs: Mapping[str, Any]) -> dict[str, Any]:
        out = self.encoder.step(t_s, inputs)
        if "reading" in out:
            self.dropped = not self.dropped
            if self.dropped:
                del out["reading"]
        return out
