"""The trajectory planner's parameters: the reference's shape and the feasibility check
against the arm model."""

from __future__ import annotations

from robot_controller.blocks import spec
from robot_controller.core.reference import MODES
from robot_controller.parameters.schema.shared import POSITIVE, URDF, arm_model_specs, torque_max_spec, world_waits_spec
from robot_controller.parameters.spec import ParamSpec

# One line per parameter: the schema reads as a table.
# fmt: off
TRAJECTORY_PLANNER_PARAMS: tuple[ParamSpec, ...] = (
    ParamSpec("mode", str, "sine", "reference shape", choices=MODES),
    ParamSpec("joint_count", int, 1, "number of joints to plan for", minimum=1, read_only=True),
    ParamSpec("amplitude", float, [1.0], "amplitude (sine, square, chirp) or step size, rad", per_joint=True),
    ParamSpec("frequency_hz", float, 0.5, "frequency of sine and square, start frequency of chirp, Hz", minimum=0.0),
    ParamSpec("offset", float, [0.0], "centre (sine, square, chirp), start (step) or hold position, rad", per_joint=True),
    ParamSpec("step_time_s", float, 1.0, "time of the step after the planner starts, s", minimum=0.0),
    ParamSpec("step_shaping", str, "min_time", "step as a jump, or shaped into the fastest move within max_acceleration (bang-bang), which the arm can follow inside its torque limit", choices=("none", "min_time")),
    ParamSpec("max_acceleration", float, 60.0, "acceleration limit of a shaped step, rad/s² (the reference arm: (10 − 2.45) N·m / 0.0833 kg·m² ≈ 90 at most; 60 leaves the feedback room)", **POSITIVE),
    ParamSpec("end_frequency_hz", float, 2.0, "end frequency of the chirp, Hz", minimum=0.0),
    ParamSpec("sweep_time_s", float, 10.0, "duration of one chirp sweep, s", **POSITIVE),
    ParamSpec("publish_rate_hz", float, 100.0, f"rate of {spec.REFERENCE.topic}, Hz", minimum=1.0, maximum=1000.0),
    world_waits_spec(f"sample on {spec.CLOCK.topic} ticks (the sim's clock) instead of a timer"),
    URDF,
    # The arm model the trajectory is checked against: the controller's (`run` passes pid_controller's
    # model_* values on to these when they are empty; set, they must equal the controller's).
    *arm_model_specs(
        "the arm model the trajectory is checked against, the controller's (run passes its values on; set "
        "here, they must equal it): "
    ),
    torque_max_spec("actuator torque limit the trajectory is checked against; must equal motor_node's"),
    ParamSpec("feasibility", str, "scale", "a trajectory that needs more than the usable torque (torque_max less feasibility_margin, from the arm model's inverse dynamics along the path: the URDF's, or the model_* values over it, as the controller's): slow it in time until it fits (frequencies, or a shaped step's max_acceleration), refuse it, or run it anyway with a warning", choices=("scale", "refuse", "ignore")),
    ParamSpec("feasibility_margin", float, 0.2, "fraction of torque_max kept free for the feedback when checking the trajectory (0.2: the path may use 80 %)", minimum=0.0, maximum=0.9),
    # ros2_controllers' JointTrajectoryController's face (docs/moveit.md).
    ParamSpec("controller_name", str, "joint_trajectory_controller", f"the name clients know the arm's trajectory controller by: the action {spec.FOLLOW_JOINT_TRAJECTORY.action_for('<controller_name>')} and the topic {spec.CONTROLLER_WAYPOINTS.topic_for('<controller_name>')} (as JointTrajectoryController's; MoveIt's moveit_controllers.yaml names it)", read_only=True),
    ParamSpec("allow_partial_joints_goal", bool, False, "take a trajectory naming only some joints (the others hold where their reference is), as JointTrajectoryController's parameter; else it is refused (INVALID_JOINTS)"),
    ParamSpec("path_tolerance", float, 0.0, "default path tolerance of a FollowJointTrajectory goal, rad (m on a slider): |desired − actual| beyond it aborts the goal (PATH_TOLERANCE_VIOLATED); 0: none, unless the goal gives one", minimum=0.0),
    ParamSpec("goal_tolerance", float, 0.01, "default goal tolerance, rad (m): the goal succeeds once every joint is this close to its last point; 0: none (it succeeds at the trajectory's end)", minimum=0.0),
    ParamSpec("goal_time_tolerance_s", float, 1.0, "default time after the trajectory's end within which every joint must be within its goal tolerance, s (else GOAL_TOLERANCE_VIOLATED); 0: no limit", minimum=0.0),
    ParamSpec("stop_deceleration", float, 20.0, "deceleration of the reference's stops, rad/s² (m/s²): a cancelled or aborted goal's stop, and the stop a trajectory makes first when joining it directly would swing past its first point", **POSITIVE),
)
# fmt: on
