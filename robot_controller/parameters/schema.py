"""Every parameter of every node, one entry each: type, default, description,
accepted range or choices, per joint or not, read-only or not (in the spirit
of generate_parameter_library). The nodes declare their parameters from
here, ``robot-controller params`` prints them, and ``params --yaml`` writes
the defaults as a ROS 2 parameter file.

Longer than our ~250-line guideline: one entry per parameter of every node, by design.
"""

from __future__ import annotations

from enum import Enum

from robot_controller.core.feedforward import FeedforwardMode
from robot_controller.core.pid import AntiWindup, DerivativeSource
from robot_controller.core.trajectory import MODES
from robot_controller.parameters.spec import ParamSpec

NODES = ("simulator", "motor_node", "sensor_node", "pid_controller", "trajectory_planner")
# Parameters rclpy declares on every node by itself.
ROS_BUILTIN = ("use_sim_time", "start_type_description_service")
# Parameters a node declares to report something it works out (read-only in effect); a parameter file
# that holds them (`robot-controller param dump`) is read without them.
REPORTED = ("law_in_force",)


def _values(enum: type[Enum]) -> tuple[str, ...]:
    return tuple(member.value for member in enum)


URDF = ParamSpec(
    "urdf_path",
    str,
    "",
    "robot description (URDF file); empty means the package's reference arm " "(description/one_dof_arm.urdf)",
    read_only=True,
)


def arm_model_specs(lead: str = "arm model: ") -> tuple[ParamSpec, ...]:
    """The arm model's per-joint values (empty: the URDF's), for the controller and, led by ``lead``,
    for the planner that checks its trajectory against the same model."""
    common = {"per_joint": True, "allow_empty": True, "read_only": True}
    return (
        ParamSpec(
            "model_inertia",
            float,
            [],
            lead + "each joint's inertia about its axis, kg·m² (empty: the URDF's)",
            minimum=0.0,
            exclusive_minimum=True,
            **common,
        ),
        ParamSpec(
            "model_damping",
            float,
            [],
            lead + "each joint's viscous damping, N·m·s/rad (empty: the URDF's)",
            minimum=0.0,
            **common,
        ),
        ParamSpec(
            "model_coulomb_friction",
            float,
            [],
            lead + "each joint's Coulomb (dry) friction, N·m (empty: the URDF's)",
            minimum=0.0,
            **common,
        ),
        ParamSpec(
            "model_gravity_torque",
            float,
            [],
            lead + "gravity's torque on each joint with its link horizontal (m·g·l_c), N·m; the torque is this "
            "times cos(q), q = 0 horizontal as in the reference arm (empty: the URDF's)",
            **common,
        ),
        ParamSpec(
            "model_payload",
            float,
            [],
            lead + "a load on the last joint's link beyond the URDF: [mass_kg, x_m, y_m, z_m], a point mass at "
            "that point of the link's frame (empty: none; identify fits it on a chain of joints)",
            length=4,
            allow_empty=True,
            read_only=True,
        ),
    )


def torque_max_spec(description: str) -> ParamSpec:
    """A node's torque limit per joint; empty (the default): each joint's URDF effort limit."""
    return ParamSpec(
        "torque_max",
        float,
        [],
        description + ", N·m (one per joint, or one for all; empty: each joint's URDF effort limit)",
        per_joint=True,
        allow_empty=True,
        minimum=0.0,
        exclusive_minimum=True,
    )


# Rates have a floor and a ceiling this stack can keep: a rate beyond it starves
# the loop, one below it leaves the watchdog with nothing to watch.
SCHEMA: dict[str, tuple[ParamSpec, ...]] = {
    "simulator": (
        URDF,
        ParamSpec(
            "payload",
            float,
            [],
            "a load the arm carries that its URDF lacks: [mass_kg, x_m, y_m, z_m], a point mass at that point "
            "of the last joint's link's frame (empty: none)",
            length=4,
            allow_empty=True,
            read_only=True,
        ),
        ParamSpec(
            "physics_rate_hz", float, 1000.0, "physics steps per second (MuJoCo)", minimum=100.0, maximum=10000.0
        ),
        ParamSpec(
            "publish_rate_hz",
            float,
            100.0,
            "rate of /sim/joint_states (true state), Hz; a whole divisor of physics_rate_hz",
            minimum=10.0,
            maximum=1000.0,
        ),
        ParamSpec(
            "initial_position",
            float,
            [0.0],
            "initial joint position, rad (one per joint, or one for all)",
            per_joint=True,
        ),
        ParamSpec(
            "wait_for_first_command",
            bool,
            True,
            "keep the arm still (brakes on) until the first effort arrives, so start-up order does not matter",
        ),
        ParamSpec(
            "lockstep",
            bool,
            False,
            "sim-time lockstep: publish /clock and advance one control period per effort",
            read_only=True,
        ),
        ParamSpec(
            "control_rate_hz",
            float,
            100.0,
            "control rate the lockstep advances by (one period per effort), Hz",
            minimum=10.0,
            maximum=1000.0,
        ),
        ParamSpec(
            "drive_timeout_s",
            float,
            0.05,
            "efforts missing this long (wall clock) engage the holding brakes and cut the torque (category 0), s",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec(
            "brake_torque_nm",
            float,
            50.0,
            "holding torque of each joint's brake, N·m (stops the reference arm from 3 rad/s in about 5 ms)",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        # A disturbance at a set physics time (the tutorial's exercise 2), the same input as /sim/disturbance:
        # a lockstep run reproduces it exactly.
        ParamSpec(
            "disturbance_torque_nm",
            float,
            [0.0],
            "external torque on each joint from disturbance_start_s, N·m (0: none)",
            per_joint=True,
            minimum=-100.0,
            maximum=100.0,
        ),
        ParamSpec(
            "disturbance_start_s",
            float,
            0.0,
            "physics time the disturbance starts at, s (the physics starts with the first command)",
            minimum=0.0,
        ),
        ParamSpec(
            "disturbance_duration_s",
            float,
            1.0,
            "how long the disturbance acts, s",
            minimum=0.0,
            exclusive_minimum=True,
            maximum=60.0,
        ),
    ),
    "motor_node": (
        URDF,
        torque_max_spec("actuator torque limit"),
        ParamSpec(
            "lag_time_constant_s", float, 0.0, "first-order actuator lag time constant, s (0 = none)", minimum=0.0
        ),
        ParamSpec(
            "command_timeout_s",
            float,
            0.05,
            "no valid /joint_commands for this long: zero torque and brake request (category 0) until commands return, s",
            minimum=0.0,
            exclusive_minimum=True,
        ),
    ),
    "sensor_node": (
        ParamSpec("rate_hz", float, 100.0, "sensor sample rate, Hz", minimum=10.0, maximum=1000.0),
        ParamSpec("position_noise_std", float, 0.005, "Gaussian position noise σ, rad", minimum=0.0),
        ParamSpec("velocity_noise_std", float, 0.02, "Gaussian velocity noise σ, rad/s", minimum=0.0),
        ParamSpec("position_bias", float, 0.0, "constant position bias, rad"),
        ParamSpec("quantization", float, 0.0, "position quantisation step, rad (0 = none)", minimum=0.0),
        ParamSpec("seed", int, 0, "random seed of the noise; -1 draws one from the OS", minimum=-1),
        ParamSpec(
            "delay_s",
            float,
            0.0,
            "each reading is published this late, stamped with its sample time, s (a slow encoder or bus)",
            minimum=0.0,
            maximum=1.0,
        ),
    ),
    "pid_controller": (
        URDF,
        ParamSpec(
            "controller_type",
            str,
            "lqr",
            "control law behind the node: pid (the gains below), lqr (gains from a discrete Riccati design with "
            "lqr_q and lqr_r), or a law of your own: an installed plugin's name, package.module:Class or "
            "path/to/file.py:Class (docs/own-controller.md), chosen at start; its declared parameters are law.NAME",
        ),
        ParamSpec(
            "stop_law",
            str,
            "lqr",
            "under a law of your own: the built-in law (with the gains here) that brings the arm to rest if it "
            "raises, returns a non-finite torque or the wrong shape, or overruns law_budget_s",
            choices=("pid", "lqr"),
        ),
        ParamSpec(
            "law_budget_s",
            float,
            0.005,
            "under a law of your own: the wall time its update may take per tick, s; longer is a fault "
            "(controlled stop); lockstep and wall clock alike",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec(
            "lqr_q",
            float,
            [10000.0, 10000.0, 1.0],
            "LQR state weights on [∫error, error, velocity error]",
            length=3,
            minimum=0.0,
        ),
        ParamSpec("lqr_r", float, 10.0, "LQR weight on the feedback torque", minimum=0.0, exclusive_minimum=True),
        ParamSpec(
            "reference_inertia",
            float,
            1.0 / 12.0,
            "the joint inertia lqr_r and the Kalman filter's torque noise figures are for, kg·m² (the reference "
            "arm's); on each joint the LQR's torque weight is lqr_r·(this / its inertia at design_position)² and the "
            "observer's torque σs are scaled by (its inertia / this), so every joint gets the same closed-loop "
            "poles and the same observer (0: the values as they are on every joint)",
            minimum=0.0,
            read_only=True,
        ),
        ParamSpec(
            "estimator",
            str,
            "kalman",
            "state estimate the law acts on: the raw reading, or a Kalman filter on position and velocity with the applied torque as input",
            choices=("none", "kalman"),
        ),
        ParamSpec(
            "kalman_position_noise_std",
            float,
            0.005,
            "Kalman filter: encoder position noise σ, rad",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec(
            "kalman_velocity_noise_std",
            float,
            0.02,
            "Kalman filter: encoder velocity noise σ, rad/s",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec(
            "kalman_acceleration_noise_std",
            float,
            0.005,
            "Kalman filter: unmodelled acceleration σ, rad/s², while the readings agree with the filter: small, so that it trusts the arm model and averages the sensor noise away over about a second. Lockstep only: on the wall clock the filter runs at its mismatch settings and takes no jumps",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec(
            "disturbance_observer",
            bool,
            True,
            "Kalman filter: also estimate an unknown external torque on each joint (a push, a load, what the arm model gets wrong) and subtract it from the command, within torque_max (a disturbance observer); no effect with estimator none",
        ),
        ParamSpec(
            "kalman_disturbance_noise_std",
            float,
            0.0001,
            "disturbance observer: how fast the external torque may change between jumps (σ of its random walk), N·m/√s, while the readings agree with the filter; a push is followed as a jump (kalman_disturbance_jump_sigma)",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec(
            "kalman_disturbance_jump_sigma",
            float,
            5.0,
            "disturbance observer: a reading this many σ from the filter's prediction, among readings that agree with it, is taken as a sudden external torque (a push), which the observer follows within a period or two; 0: never. Lockstep only (on the wall clock a push begins anywhere inside a period)",
            minimum=0.0,
        ),
        ParamSpec(
            "kalman_mismatch_acceleration_noise_std",
            float,
            2.0,
            "Kalman filter: unmodelled acceleration σ, rad/s², it moves to while its readings disagree with it (an arm unlike its model, readings later than their stamps), to follow the readings rather than the model",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec(
            "kalman_command_timing_uncertainty_s",
            float,
            0.01,
            "Kalman filter, on the wall clock only: how uncertain the instant is from which a new command acts on the arm (the command path's latency and jitter), s; a change of command Δτ leaves the velocity that much less certain (Δτ·this/inertia). Lockstep applies each command from its tick: 0 there",
            minimum=0.0,
            maximum=0.1,
        ),
        ParamSpec(
            "kalman_mismatch_disturbance_noise_std",
            float,
            0.3,
            "disturbance observer: the external torque's σ, N·m/√s, it moves to while the readings disagree with the filter",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec("control_rate_hz", float, 100.0, "control loop rate, Hz", minimum=10.0, maximum=1000.0),
        ParamSpec(
            "trigger",
            str,
            "measurement",
            "what starts a control step: a timer at control_rate_hz (the tutorial's way) or each new sensor reading (read-update-write, no phase delay; a timer still runs the watchdog)",
            choices=("timer", "measurement"),
        ),
        ParamSpec("kp", float, [50.0], "proportional gain, N·m/rad", per_joint=True, minimum=0.0),
        ParamSpec("ki", float, [10.0], "integral gain, N·m/(rad·s)", per_joint=True, minimum=0.0),
        ParamSpec("kd", float, [5.0], "derivative gain, N·m·s/rad", per_joint=True, minimum=0.0),
        ParamSpec(
            "integral_limit",
            float,
            [10.0],
            "clamp on the integral of the error, rad·s (anti_windup clamp)",
            per_joint=True,
            minimum=0.0,
        ),
        ParamSpec("anti_windup", str, "conditional_integration", "anti-windup mode", choices=_values(AntiWindup)),
        ParamSpec(
            "back_calculation_time_s",
            float,
            0.1,
            "tracking time constant of back-calculation anti-windup, s",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec(
            "derivative_source",
            str,
            "velocity_error",
            "what the D term differentiates",
            choices=_values(DerivativeSource),
        ),
        ParamSpec("derivative_filter_time_s", float, 0.0, "first-order filter on the D term, s (0 = off)", minimum=0.0),
        ParamSpec(
            "feedforward",
            str,
            "full",
            "model feedforward from the arm model (the URDF, or the model_* values below)",
            choices=_values(FeedforwardMode),
        ),
        ParamSpec(
            "feedback_decoupling",
            bool,
            True,
            "on a chain of joints, pass the feedback torques through M(q)·diag(M(q))⁻¹ (the arm model's mass "
            "matrix), so each joint gets the acceleration its own gains ask for whatever the others do, as "
            "computed-torque control does; no effect on one joint or without the arm model",
        ),
        # The arm model every model-based part uses (feedforward, Kalman prediction, LQR design, latency
        # compensation, the controlled stop): the URDF's unless these say otherwise (`robot-controller identify`
        # writes them). Any one set: tau = I·a + b·v + f_c·sign(v) + G·cos(q) per joint, the rest from the URDF.
        *arm_model_specs(),
        torque_max_spec("output limit"),
        ParamSpec(
            "design_position",
            float,
            [],
            "the pose the LQR gains and the delay margin are designed at (each joint's inertia there), rad per "
            "joint (empty: every joint at 0, or the nearest end of its range); --robot sets the robot's home pose",
            per_joint=True,
            allow_empty=True,
            read_only=True,
        ),
        ParamSpec("slew_rate_limit", float, 0.0, "maximum rate of change of the command, N·m/s (0 = off)", minimum=0.0),
        ParamSpec(
            "reference_extrapolation",
            bool,
            True,
            "evaluate the latest reference at the tick time with its velocity and acceleration",
        ),
        ParamSpec(
            "latency_compensation",
            bool,
            True,
            "advance the measurement from its stamp to the tick time with its velocity",
        ),
        ParamSpec(
            "watchdog_periods",
            int,
            5,
            "control periods without valid sensor data before a controlled stop on the arm model's estimate (category 2)",
            minimum=1,
        ),
        ParamSpec(
            "sensor_timeout_s",
            float,
            1.0,
            "readings missing this long end the controlled stop: no command, the drive's brake holds (category 1), s",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec(
            "max_reading_age_s",
            float,
            0.1,
            "a reading older than this when it arrives (or stamped this far in the future) is dropped and does not count as a sign of life, s",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec(
            "stop_deceleration",
            float,
            20.0,
            "deceleration of a controlled stop (sensor or planner lost), rad/s²",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec(
            "reacquire_acceleration",
            float,
            20.0,
            "acceleration limit of the blend from where the arm is back onto the trajectory after a fault, rad/s²",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec(
            "log_period_s",
            float,
            1.0,
            "period of the target/actual/error/torque log line, s",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec(
            "diagnostics_period_s",
            float,
            1.0,
            "period of the loop-health report on /diagnostics, s",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec(
            "lockstep",
            bool,
            False,
            "compute on each measurement once the due reference is in (sim-time lockstep), not on a timer",
            read_only=True,
        ),
    ),
    "trajectory_planner": (
        ParamSpec("mode", str, "sine", "reference shape", choices=MODES),
        ParamSpec("joint_count", int, 1, "number of joints to plan for", minimum=1, read_only=True),
        ParamSpec("amplitude", float, [1.0], "amplitude (sine, square, chirp) or step size, rad", per_joint=True),
        ParamSpec(
            "frequency_hz", float, 0.5, "frequency of sine and square, start frequency of chirp, Hz", minimum=0.0
        ),
        ParamSpec(
            "offset", float, [0.0], "centre (sine, square, chirp), start (step) or hold position, rad", per_joint=True
        ),
        ParamSpec("step_time_s", float, 1.0, "time of the step after the planner starts, s", minimum=0.0),
        ParamSpec(
            "step_shaping",
            str,
            "min_time",
            "step as a jump, or shaped into the fastest move within max_acceleration (bang-bang), which the arm can follow inside its torque limit",
            choices=("none", "min_time"),
        ),
        ParamSpec(
            "max_acceleration",
            float,
            60.0,
            "acceleration limit of a shaped step, rad/s² (the reference arm: (10 − 2.45) N·m / 0.0833 kg·m² ≈ 90 at most; 60 leaves the feedback room)",
            minimum=0.0,
            exclusive_minimum=True,
        ),
        ParamSpec("end_frequency_hz", float, 2.0, "end frequency of the chirp, Hz", minimum=0.0),
        ParamSpec("sweep_time_s", float, 10.0, "duration of one chirp sweep, s", minimum=0.0, exclusive_minimum=True),
        ParamSpec("publish_rate_hz", float, 100.0, "rate of /trajectory, Hz", minimum=1.0, maximum=1000.0),
        ParamSpec(
            "lockstep", bool, False, "sample on /clock ticks (sim-time lockstep) instead of a timer", read_only=True
        ),
        URDF,
        # The arm model the trajectory is checked against: the controller's (`run` passes pid_controller's
        # model_* values on to these when they are empty; set, they must equal the controller's).
        *arm_model_specs(
            "the arm model the trajectory is checked against, the controller's (run passes its values on; set "
            "here, they must equal it): "
        ),
        torque_max_spec("actuator torque limit the trajectory is checked against; must equal motor_node's"),
        ParamSpec(
            "feasibility",
            str,
            "scale",
            "a trajectory that needs more than the usable torque (torque_max less feasibility_margin, from the arm model's inverse dynamics along the path: the URDF's, or the model_* values over it, as the controller's): slow it in time until it fits (frequencies, or a shaped step's max_acceleration), refuse it, or run it anyway with a warning",
            choices=("scale", "refuse", "ignore"),
        ),
        ParamSpec(
            "feasibility_margin",
            float,
            0.2,
            "fraction of torque_max kept free for the feedback when checking the trajectory (0.2: the path may use 80 %)",
            minimum=0.0,
            maximum=0.9,
        ),
    ),
}


def spec_of(node: str, name: str) -> ParamSpec:
    for spec in SCHEMA[node]:
        if spec.name == name:
            return spec
    raise KeyError(f"{node}.{name}")


def has(node: str, name: str) -> bool:
    return any(spec.name == name for spec in SCHEMA[node])


def defaults() -> dict[str, dict]:
    """Every node's default values (the reference scenario with the default controller)."""
    return {node: {spec.name: spec.default_value() for spec in specs} for node, specs in SCHEMA.items()}
