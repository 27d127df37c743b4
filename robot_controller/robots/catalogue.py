"""The robots ``--robot`` selects, each a parameter layer over the schema's defaults and under the preset and the
user's files: a URDF, a home pose and a default sine about it within its limits; four built in, any other from its
description. It sets no torque limit: an empty ``torque_max`` is each joint's URDF effort limit."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any

from robot_controller import resources
from robot_controller.robots.description import describe


@dataclass(frozen=True)
class Robot:
    """``urdf`` returns its URDF file ("": the reference arm); ``home_position`` (where it starts and the trajectory
    is centred) and the default sine's ``amplitude`` are rad per joint (m on a slide); ``note``: what was changed to
    load its description (fingers held still, meshes dropped)."""

    name: str
    summary: str
    urdf: Callable[[], str]
    home_position: tuple[float, ...]
    amplitude: tuple[float, ...]
    frequency_hz: float
    note: str = ""
    rated_payload_kg: float = 0.0  #: kg, the maker's rated payload (the controller allows for one it does not know)
    #: rad (m on a prismatic joint): how far the true position may be from the reference in force, start included,
    #: for a run to be ``ok`` (``run --tracking-band``)
    tracking_band_rad: float = 0.02

    def layer(self) -> dict[str, dict[str, Any]]:
        if not (urdf := self.urdf()):
            return {}  # the schema's defaults are the reference arm's
        home = list(self.home_position)
        return {
            "simulator": {"urdf_path": urdf, "initial_position": home},
            "motor_node": {"urdf_path": urdf},
            "sensor_node": {"urdf_path": urdf},  # (for its joints' units)
            # Without readings the controller stops on its model open loop, which gravity makes
            # unstable on a chain of joints: the brakes take over after CHAIN_SENSOR_TIMEOUT_S.
            "pid_controller": {"urdf_path": urdf, "design_position": home, "sensor_timeout_s": CHAIN_SENSOR_TIMEOUT_S}
            | ({"rated_payload_kg": self.rated_payload_kg} if self.rated_payload_kg else {}),
            "trajectory_planner": {
                "urdf_path": urdf,
                "joint_count": len(home),
                "mode": "sine",
                "offset": home,
                "amplitude": list(self.amplitude),
                "frequency_hz": self.frequency_hz,
            },
        }


def _shipped(filename: str) -> Callable[[], str]:
    return lambda: str(resources.share_dir() / "description" / filename)


DEFAULT_ROBOT = "one_dof"
DESCRIBED_FREQUENCY_HZ = 0.25  #: of the default sine of an arm known by its description
#: s, how long a chain of joints is stopped on its model alone before the brakes hold it
CHAIN_SENSOR_TIMEOUT_S = 0.2

ROBOTS: dict[str, Robot] = {
    robot.name: robot
    for robot in (
        Robot(
            "one_dof",
            "the tutorial's arm: one revolute joint, a 0.5 m 1 kg link, 10 N·m",
            lambda: "",
            (0.0,),
            (1.0,),
            0.5,
        ),
        Robot(
            "planar2",
            "a two-link planar arm in a vertical plane (description/planar2_arm.urdf), 30 and 10 N·m",
            _shipped("planar2_arm.urdf"),
            (0.0, 0.0),
            (0.6, 0.8),
            0.5,
        ),
        Robot(
            "scara",
            "a small SCARA (description/scara_arm.urdf): two vertical revolute joints, 30 and 10 N·m, "
            "and a vertical prismatic quill, 0.2 m, 40 N",
            _shipped("scara_arm.urdf"),
            (0.0, 0.6, 0.1),
            (0.6, 0.8, 0.05),
            0.5,
        ),
        Robot(
            "panda",
            "the Franka Emika Panda's 7 arm joints (example-robot-data), 87 and 12 N·m; the fingers held still",
            lambda: str(describe("panda").path),
            # The "ready" pose of the Panda's SRDF (example-robot-data's panda.srdf, group state "default").
            (0.0, -0.785398, 0.0, -2.35619, 0.0, 1.5707, 0.785398),
            (0.4, 0.3, 0.4, 0.4, 0.5, 0.4, 0.6),
            0.25,
            rated_payload_kg=3.0,  # Franka's datasheet
        ),
    )
}


def robot(name: str) -> Robot:
    """One of ``ROBOTS``, else the arm ``name`` names by its description; a ConfigError if none can run."""
    return ROBOTS[name] if name in ROBOTS else _described(name)


@lru_cache(maxsize=16)
def _described(name: str) -> Robot:
    arm = describe(name, ROBOTS)
    path = str(arm.path)
    return Robot(arm.name, path, lambda: path, arm.home, arm.amplitude, DESCRIBED_FREQUENCY_HZ, arm.note)


def arm_name(name: str, urdf_path: str) -> str:
    """The arm a run drives: robot ``name``'s, or the file's stem where a config file gave another URDF."""
    return robot(name).name if urdf_path == robot(name).urdf() else Path(urdf_path).stem


def urdf_of(name: str) -> Path:
    return resources.resolve_urdf(robot(name).urdf())
