"""The camera and the vision chained in one process (the in-process loop's sensor for ``--sensing camera``): each true
state goes to the camera, each image it writes to the vision, whose reading is the chain's; as the graph on sim time
passes them, a value reaching its reader at the tick it was written."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from robot_controller.blocks.block import Log
from robot_controller.blocks.camera import Camera
from robot_controller.blocks.vision import Vision


class CameraChain:
    inputs = ("true_state",)
    outputs = ("reading",)

    def __init__(
        self, camera_params: Mapping[str, Any], vision_params: Mapping[str, Any], log: Log, *, world_waits: bool
    ) -> None:
        self.camera = Camera(camera_params, log, world_waits=world_waits)
        self.vision = Vision(vision_params, log, world_waits=world_waits)

    def start(self) -> dict[str, Any]:
        return {}

    def wake_period_s(self) -> float | None:
        return None

    def check_params(self, params: Mapping[str, Any]) -> None:
        self.vision.check_params(params)

    def set_params(self, params: Mapping[str, Any], changed: set[str]) -> None:
        self.vision.set_params(params, changed)

    def step(self, t_s: float, inputs: Mapping[str, Any]) -> dict[str, Any]:
        image = self.camera.step(t_s, inputs).get("image")
        if image is None:
            return {}
        reading = self.vision.step(t_s, {"image": image}).get("reading")
        return {} if reading is None else {"reading": reading}

    def close(self) -> None:
        self.camera.close()
