"""A sensor that reports every other sample of the encoder's (a bus that drops half the frames): the second sensor
block, chosen by ``sensor_node``'s ``block: every_other_tick``. The controller's estimator bridges the gaps."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from robot_controller.blocks.encoder import Encoder


class EveryOtherTick(Encoder):
    dropped = True  #: the last sample was dropped: the next is reported (the first is)

    def step(self, t_s: float, inputs: Mapping[str, Any]) -> dict[str, Any]:
        out = super().step(t_s, inputs)
        if "reading" in out:
            self.dropped = not self.dropped
            if self.dropped:
                del out["reading"]
        return out
