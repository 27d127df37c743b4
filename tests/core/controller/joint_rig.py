"""A JointController test rig: an exact period, numbers for times, a ramp
planner and an arm read exactly on it (no ROS, no sleeping)."""

from functools import lru_cache

import numpy as np

from robot_controller import resources
from robot_controller.core.controller import ControllerConfig, ControlOutput, JointController, Status
from robot_controller.core.model import ArmDynamics
from tests.core import configs

PERIOD = 1 / 64  #: s: tick times k·PERIOD, and the watchdog's threshold, are exact in binary
TORQUE_MAX = 10.0


def one(x: float) -> np.ndarray:
    return np.array([float(x)])


@lru_cache(maxsize=1)
def arm() -> ArmDynamics:
    return ArmDynamics(resources.default_urdf())


def config(**kw) -> ControllerConfig:
    """The rig's controller: a plain PID on its exact period (``configs.CONTROLLER``), ``kw`` over it."""
    return configs.controller(**({"control_period_s": PERIOD, "pid": configs.pid(output_limit=[TORQUE_MAX])} | kw))


def run(
    c: JointController,
    ticks,
    *,
    speed: float = 0.0,
    planner: bool = True,
    readings: bool = True,
    every: int = 1,
    arm_at: float | None = None,
) -> list[ControlOutput]:
    """Tick ``c`` at k·PERIOD for k in ``ticks``: the planner on a ramp of ``speed``
    rad/s (a sample every ``every`` ticks), the arm read exactly on it (or at ``arm_at``)."""
    outs = []
    for k in ticks:
        t = k * PERIOD
        if planner and k % every == 0:
            c.set_reference(t, one(speed * t), one(speed), one(0.0), sample_time_s=t)
        if readings:
            c.set_measurement(t, t, one(speed * t if arm_at is None else arm_at), one(speed))
        outs.append(c.update(t))
    return outs


def tracking(speed: float = 0.0, **kw) -> JointController:
    """A controller past its start-up blend (0.2 s), tracking a ramp, at tick 16 (0.25 s)."""
    c = JointController(config(**kw), 1)
    outs = run(c, range(17), speed=speed)
    assert outs[-1].status is Status.OK
    return c
