"""The sensor node's parameters: its rate and the noise, bias, quantisation and delay of its readings."""

from __future__ import annotations

from robot_controller.blocks import spec
from robot_controller.blocks.spec import BLOCKS
from robot_controller.parameters.schema.shared import URDF, world_waits_spec
from robot_controller.parameters.spec import ParamSpec

# One line per parameter: the schema reads as a table.
# fmt: off
SENSOR_NODE_PARAMS: tuple[ParamSpec, ...] = (
    URDF,
    ParamSpec("block", str, "encoder", "the sensor block it runs (one of the graph spec's; fixed at start)", choices=tuple(BLOCKS["sensor_node"]), read_only=True),
    ParamSpec("rate_hz", float, 100.0, "sensor sample rate, Hz", minimum=10.0, maximum=1000.0),
    ParamSpec("position_noise_std", float, 0.005, "Gaussian position noise σ, rad (m on a prismatic joint)", minimum=0.0),
    ParamSpec("velocity_noise_std", float, 0.02, "Gaussian velocity noise σ, rad/s (m/s on a prismatic joint)", minimum=0.0),
    ParamSpec("position_bias", float, 0.0, "constant position bias, rad"),
    ParamSpec("quantization", float, 0.0, "position quantisation step, rad (0 = none)", minimum=0.0),
    ParamSpec("seed", int, 0, "random seed of the noise; -1 draws one from the OS", minimum=-1),
    ParamSpec("delay_s", float, 0.0, "each reading is published this late, stamped with its sample time, s (a slow encoder or bus)", minimum=0.0, maximum=1.0),
    world_waits_spec(f"on the sim's clock: {spec.READING.topic} is transient local, so a controller that matches late still gets the reading its tick waits for"),
)
# fmt: on
