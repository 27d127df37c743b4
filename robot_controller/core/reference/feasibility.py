"""Whether the arm can follow a trajectory inside its torque limit, and how
much slower it must go if it cannot.

The torque a path needs is the arm's inverse dynamics along it (MuJoCo's
``mj_inverse`` through :class:`~robot_controller.core.model.plant.ArmDynamics`:
inertia·q̈ + damping·q̇ + Coriolis + gravity, or the controller's
:class:`~robot_controller.core.model.arm_model.JointArmModel` when it has ``model_*``
values), sampled densely over what repeats or happens once: one period of a
sine or square, a chirp's sweep up and its sweep back down (it is
continuous at its turns: :class:`~robot_controller.core.reference.trajectory.Chirp`),
the move of a step, the position of a hold. A fraction ``margin`` of the
limit is kept free for the feedback law (0.2: the path may use 80 %).

Slowing a path in time by ``k`` (:func:`~robot_controller.core.reference.trajectory.time_scaled`)
divides its velocities by ``k`` and its accelerations by ``k²``; the
positions, and so gravity, stay. The smallest ``k`` that fits is found by
bisection on the inverse dynamics itself (any Coriolis, damping and gravity
terms included, no closed form assumed), then checked on the scaled
trajectory. If gravity alone along the path exceeds the usable torque, no
``k`` helps, and the result says so.

A jump (an unshaped step, a square wave) has no finite acceleration to
check: only holding its levels is. Shape a step (``step_shaping: min_time``)
to have its move checked.

No rclpy here; ``dynamics`` is anything with ``torque(q, v, a)``.
The check is :mod:`robot_controller.core.reference.feasibility_check`, the plan that acts on its
result :mod:`robot_controller.core.reference.feasibility_plan`; their names are importable from here.
"""

from robot_controller.core.reference.feasibility_check import (
    DEFAULT_MARGIN,
    MAX_SCALE,
    MIN_SAMPLES,
    POLICIES,
    RELATIVE_TOLERANCE,
    SAMPLES_PER_CYCLE,
    Feasibility,
    InverseDynamics,
    check,
    peak_torque,
    sample_times,
)
from robot_controller.core.reference.feasibility_plan import Plan, describe_scaling, plan

__all__ = [
    "DEFAULT_MARGIN",
    "MAX_SCALE",
    "MIN_SAMPLES",
    "POLICIES",
    "RELATIVE_TOLERANCE",
    "SAMPLES_PER_CYCLE",
    "Feasibility",
    "InverseDynamics",
    "Plan",
    "check",
    "describe_scaling",
    "peak_torque",
    "plan",
    "sample_times",
]
