"""The robots ``--robot NAME`` selects, each a parameter layer: a URDF, a home pose and a default
sine about it that the arm follows within its limits.

The layer goes over the schema's defaults and under the preset and the user's ``--config`` files.
It sets no torque limit: an empty ``torque_max`` is each joint's URDF effort limit
(``parameters.torque_limits``), whichever URDF a node is given.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robot_controller import resources
from robot_controller.core.errors import ConfigError


@dataclass(frozen=True)
class Robot:
    """:param urdf: returns the robot's URDF file (empty path: the package's reference arm)
    :param home_position: rad per joint, where the arm starts and the trajectory is centred
    :param amplitude: rad per joint, of the default sine about the home pose
    :param frequency_hz: of the default sine
    """

    name: str
    summary: str
    urdf: Callable[[], str]
    home_position: tuple[float, ...]
    amplitude: tuple[float, ...]
    frequency_hz: float

    def layer(self) -> dict[str, dict[str, Any]]:
        """The robot's parameters, as a layer of ``{node: {param: value}}``."""
        if self.name == DEFAULT_ROBOT:
            return {}  # the schema's defaults are the reference arm's
        urdf = self.urdf()
        home = list(self.home_position)
        return {
            "simulator": {"urdf_path": urdf, "initial_position": home},
            "motor_node": {"urdf_path": urdf},
            # Without readings the controller stops on its model open loop, which gravity makes
            # unstable on a chain of joints: the brakes take over after CHAIN_SENSOR_TIMEOUT_S.
            "pid_controller": {"urdf_path": urdf, "design_position": home, "sensor_timeout_s": CHAIN_SENSOR_TIMEOUT_S},
            "trajectory_planner": {
                "urdf_path": urdf,
                "joint_count": len(home),
                "mode": "sine",
                "offset": home,
                "amplitude": list(self.amplitude),
                "frequency_hz": self.frequency_hz,
            },
        }


def _planar2_urdf() -> str:
    return str(resources.share_dir() / "description" / "planar2_arm.urdf")


def _panda_urdf() -> str:
    from robot_controller.robots.panda import urdf_path

    return str(urdf_path())


DEFAULT_ROBOT = "one_dof"
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
            _planar2_urdf,
            (0.0, 0.0),
            (0.6, 0.8),
            0.5,
        ),
        Robot(
            "panda",
            "the Franka Emika Panda's 7 arm joints (example-robot-data), 87 and 12 N·m; the fingers held still",
            _panda_urdf,
            # The "ready" pose of the Panda's SRDF (example-robot-data's panda.srdf, group state "default").
            (0.0, -0.785398, 0.0, -2.35619, 0.0, 1.5707, 0.785398),
            (0.4, 0.3, 0.4, 0.4, 0.5, 0.4, 0.6),
            0.25,
        ),
    )
}


def robot(name: str) -> Robot:
    """The robot called ``name``; a ConfigError naming the choices otherwise."""
    try:
        return ROBOTS[name]
    except KeyError:
        raise ConfigError(f"--robot: unknown robot {name!r}; robots are {sorted(ROBOTS)}") from None


def urdf_of(name: str) -> Path:
    """The URDF file of robot ``name``."""
    return resources.resolve_urdf(robot(name).urdf())
