"""Every parameter of every node, one entry each (type, default, description, range or choices, per joint, read-only),
as in generate_parameter_library: the nodes declare from here, ``params`` prints them. One line per parameter: the
schema reads as a table. Rates have a floor and a ceiling: beyond it the loop starves, below it the watchdog has
nothing to watch."""

from __future__ import annotations

from collections.abc import Mapping
from enum import Enum
from typing import Any

from robot_controller.blocks import spec
from robot_controller.blocks.spec import BLOCKS
from robot_controller.core.laws import FeedforwardMode
from robot_controller.core.laws.pid import AntiWindup, DerivativeSource
from robot_controller.core.reference import MODES
from robot_controller.parameters.spec import ParamSpec

#: the range of a parameter that must be above zero: ``**POSITIVE``
POSITIVE = {"minimum": 0.0, "exclusive_minimum": True}
#: a timeout or limit that protects the arm, set only by the run's configuration: ``**SAFETY``
SAFETY = {"read_only": True, "safety": True}


def enum_values(enum: type[Enum]) -> tuple[str, ...]:
    """The choices of a string parameter that names one of ``enum``'s members."""
    return tuple(member.value for member in enum)


URDF = ParamSpec(
    "urdf_path",
    str,
    "",
    "robot description (URDF file); empty means the package's reference arm (description/one_dof_arm.urdf)",
    read_only=True,
)


def arm_model_specs(lead: str = "arm model: ") -> tuple[ParamSpec, ...]:
    """The arm model's per-joint values (empty: the URDF's), for the controller and, led by ``lead``,
    for the planner that checks its trajectory against the same model."""
    common = {"per_joint": True, "allow_empty": True, "read_only": True}
    # fmt: off
    return (
        ParamSpec("model_inertia", float, [], lead + "each joint's inertia about its axis, kg·m² (on a chain: at q = 0, the coupled model's own plus a rotor's; empty: the URDF's)", **POSITIVE, **common),
        ParamSpec("model_damping", float, [], lead + "each joint's viscous damping, N·m·s/rad (empty: the URDF's)", minimum=0.0, **common),
        ParamSpec("model_coulomb_friction", float, [], lead + "each joint's Coulomb (dry) friction, N·m (empty: the URDF's)", minimum=0.0, **common),
        ParamSpec("model_gravity_torque", float, [], lead + "gravity's torque on each joint with its link horizontal (m·g·l_c), N·m; the torque is this times cos(q), q = 0 horizontal as in the reference arm (one joint only: a chain's gravity is its links'; empty: the URDF's)", **common),
        ParamSpec("model_payload", float, [], lead + "a load on the last joint's link beyond the URDF: [mass_kg, x_m, y_m, z_m], a point mass at that point of the link's frame (empty: none; identify fits it on a chain of joints)", length=4, allow_empty=True, read_only=True),
    )
    # fmt: on


#: The name of the ROS parameter that puts a node on the sim's clock, where the world waits for each command (``run``
#: sets it for the paced world and ``--sim-time``); users' parameter files set it by this name, which stays.
WORLD_WAITS = "lockstep"


def world_waits_spec(description: str) -> ParamSpec:
    """The read-only switch to the sim's clock (:data:`WORLD_WAITS`); ``description``: what it changes in a node."""
    return ParamSpec(WORLD_WAITS, bool, False, description, read_only=True)


def world_waits(values: Mapping[str, Any]) -> bool:
    """Whether a node's parameter ``values`` put it on the sim's clock, where the world waits for each command."""
    return bool(values.get(WORLD_WAITS, False))


def torque_max_spec(description: str, safety: bool = False) -> ParamSpec:
    """A node's torque limit per joint; empty (the default): each joint's URDF effort limit, its bound
    (``safety``: the drive's, read-only)."""
    return ParamSpec(
        "torque_max",
        float,
        [],
        description + ", N·m (one per joint, or one for all; empty: each joint's URDF effort limit)",
        per_joint=True,
        allow_empty=True,
        **POSITIVE,
        **(SAFETY if safety else {}),
    )


#: Sim seconds the simulator runs past a sim-time run's duration (its ``lockstep_end_s``): the nodes may stop then.
LOCKSTEP_END_MARGIN_S = 0.5

# The simulator: the arm and its physics, the wall clock or the sim's, the brakes, the scheduled disturbance.
# fmt: off
SIMULATOR_PARAMS: tuple[ParamSpec, ...] = (
    URDF,
    ParamSpec("payload", float, [], "a load the arm carries that its URDF lacks: [mass_kg, x_m, y_m, z_m], a point mass at that point of the last joint's link's frame (empty: none)", length=4, allow_empty=True, read_only=True),
    # The plant the controller does not know (core.model.plant_variation): each on top of the URDF's own.
    ParamSpec("payload_kg", float, 0.0, "a load the arm carries that its URDF lacks, kg, a point mass at payload_offset_m (0: none; not with payload)", minimum=0.0, maximum=100.0, read_only=True),
    ParamSpec("payload_offset_m", float, [0.0, 0.0, 0.0], "where payload_kg's centre sits in the last joint's link's frame, m (x, y, z)", length=3, minimum=-2.0, maximum=2.0, read_only=True),
    ParamSpec("joint_friction_nm", float, [0.0], "Coulomb (dry) friction on each joint the URDF does not have, N·m (N on a prismatic joint), added to the URDF's own (its joint dynamics friction)", per_joint=True, minimum=0.0, maximum=1000.0, read_only=True),
    ParamSpec("joint_damping_nms", float, [0.0], "viscous damping on each joint the URDF does not have, N·m·s/rad, added to the URDF's own (its joint dynamics damping)", per_joint=True, minimum=0.0, maximum=1000.0, read_only=True),
    ParamSpec("armature_kgm2", float, [0.0], "rotor inertia reflected through each joint's gears (rotor inertia × gear ratio²), kg·m², added to the joint's inertia", per_joint=True, minimum=0.0, maximum=100.0, read_only=True),
    ParamSpec("link_mass_scale", float, [1.0], "each link's mass and inertia times this (one for every link, or one per joint: the links that joint moves)", per_joint=True, minimum=0.0, exclusive_minimum=True, maximum=10.0, read_only=True),
    ParamSpec("physics_rate_hz", float, 1000.0, "physics steps per second (MuJoCo)", minimum=100.0, maximum=10000.0),
    ParamSpec("publish_rate_hz", float, 100.0, f"rate of {spec.TRUE_STATE.topic} (true state), Hz; a whole divisor of physics_rate_hz", minimum=10.0, maximum=1000.0),
    ParamSpec("initial_position", float, [0.0], "initial joint position, rad (one per joint, or one for all)", per_joint=True),
    ParamSpec("wait_for_first_command", bool, True, "keep the arm still (brakes on) until the first effort arrives, so start-up order does not matter"),
    world_waits_spec(f"sim time: publish {spec.CLOCK.topic} and advance one control period per effort"),
    ParamSpec("real_time_factor", float, 0.0, "on sim time: world seconds per wall second the world keeps pace at, pausing with the host (the default run's 1); 0: as fast as the graph goes", minimum=0.0, maximum=10.0, read_only=True),
    ParamSpec("lockstep_end_s", float, 0.0, "on sim time: publish no tick after this sim time, s (0: none); the launcher sets it a little past --duration, so that the recorder takes every message before the nodes stop", minimum=0.0, read_only=True),
    ParamSpec("control_rate_hz", float, 100.0, "control rate sim time advances by (one period per effort), Hz: the loop's one rate, the controller's control_rate_hz (a parameter file sets it on either node, and run gives both the value; two different values are refused)", minimum=10.0, maximum=1000.0),
    ParamSpec("drive_timeout_s", float, 0.05, "efforts missing this long (wall clock) engage the holding brakes and cut the torque (category 0), s; at most 0.2 s, as the motor's command timeout", **POSITIVE, maximum=0.2, **SAFETY),
    ParamSpec("brake_torque_nm", float, 50.0, "holding torque of each joint's brake, N·m (stops the reference arm from 3 rad/s in about 5 ms)", **POSITIVE, **SAFETY),
    # A disturbance at a set physics time (the tutorial's exercise 2), the same input as the disturbance port:
    # a sim-time run reproduces it exactly.
    ParamSpec("disturbance_torque_nm", float, [0.0], "external torque on each joint from disturbance_start_s, N·m (0: none)", per_joint=True, minimum=-100.0, maximum=100.0),
    ParamSpec("disturbance_start_s", float, 0.0, "physics time the disturbance starts at, s (the physics starts with the first command)", minimum=0.0),
    ParamSpec("disturbance_duration_s", float, 1.0, "how long the disturbance acts, s", **POSITIVE, maximum=60.0),
)
# fmt: on


# The motor: the actuator's torque limit, its lag, its command timeout and the oldest command it applies.
# fmt: off
MOTOR_NODE_PARAMS: tuple[ParamSpec, ...] = (
    URDF,
    torque_max_spec("actuator torque limit", safety=True),
    ParamSpec("lag_time_constant_s", float, 0.0, "first-order actuator lag time constant, s (0 = none)", minimum=0.0),
    ParamSpec("command_timeout_s", float, 0.05, f"no valid {spec.COMMAND.topic} for this long: zero torque and brake request (category 0) until commands return, s; at most 0.2 s: a dead controller's last torque acts that long (two periods at the slowest control rate)", **POSITIVE, maximum=0.2, **SAFETY),
    ParamSpec("max_command_age_s", float, 0.03, f"a {spec.COMMAND.topic} stamped with its tick (ours are) that arrives more than this after the tick is dropped, as no command: the controller's gains survive 2 periods (20 ms) of delay it does not know of, and feedback later than that swings the arm (wall clock only: on sim time no time passes between ticks), s; at most 0.2 s, the longest command timeout: an older command is one the drive would have braked for", **POSITIVE, maximum=0.2, **SAFETY),
    world_waits_spec("on the sim's clock: each command's time is the tick it is stamped with (no timeout, no age check)"),
)
# fmt: on


# Where the camera stands and what it images: the camera renders with them and the vision solves with them (its
# calibration), so every node that declares them takes one value (LOOP_WIDE).
# fmt: off
CAMERA_PLACEMENT_PARAMS: tuple[ParamSpec, ...] = (
    ParamSpec("camera_position_m", float, [], "where the camera stands, world frame, m [x, y, z] (empty: a default that sees the arm's whole reach, along its joints' axes for a planar arm)", length=3, allow_empty=True, read_only=True),
    ParamSpec("camera_target_m", float, [], "the point the camera looks at, world frame, m [x, y, z] (empty: the default's)", length=3, allow_empty=True, read_only=True),
    ParamSpec("image_width", int, 640, "image width, px", minimum=16, maximum=4096, read_only=True),
    ParamSpec("image_height", int, 480, "image height, px", minimum=16, maximum=4096, read_only=True),
    ParamSpec("camera_fovy_deg", float, 45.0, "the camera's vertical field of view, degrees", minimum=1.0, maximum=170.0, read_only=True),
)
# The vision: markers found, the arm's joints solved over its chain (a sensor_node block, or vision_node beside the encoder).
VISION_PARAMS: tuple[ParamSpec, ...] = (
    ParamSpec("marker_calibration_error_m", float, 0.0, "σ of the error in where the vision believes each marker sits on its link, m (0: it knows exactly; a test of calibration)", minimum=0.0, maximum=0.05, read_only=True),
    ParamSpec("marker_calibration_error_rad", float, 0.0, "σ of the error in each marker's believed orientation on its link, rad", minimum=0.0, maximum=0.2, read_only=True),
    ParamSpec("corner_std_px", float, 1.0, "σ of a detected marker corner, px: the per-joint σ each reading says is worked out from it", **POSITIVE, maximum=10.0),
    ParamSpec("detections_rate_hz", float, 5.0, f"how often the image with its detections is published on {spec.DETECTIONS.topic} (JPEG) for the view and the bag, Hz (0: never)", minimum=0.0, maximum=100.0),
)
# fmt: on


# The sensor: its rate and the noise, bias, quantisation and delay of its readings.
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
    *CAMERA_PLACEMENT_PARAMS,
    *VISION_PARAMS,
    world_waits_spec(f"on the sim's clock: {spec.READING.topic} is transient local, so a controller that matches late still gets the reading its tick waits for"),
)
# fmt: on


# The camera: it renders the arm, with markers on every moving link, as a fixed camera sees it.
# fmt: off
CAMERA_NODE_PARAMS: tuple[ParamSpec, ...] = (
    URDF,
    ParamSpec("block", str, "camera", "the camera block it runs (fixed at start)", choices=tuple(BLOCKS["camera_node"]), read_only=True),
    ParamSpec("camera_rate_hz", float, 30.0, "frames a second, Hz: each frame is exposed at one of the world's states, so the rate is the nearest whole number of them (30 Hz on a 100 Hz world: every 3rd, 33.3 Hz)", minimum=1.0, maximum=100.0, read_only=True),
    *CAMERA_PLACEMENT_PARAMS,
    ParamSpec("latency_s", float, 0.03, "processing latency: each image is published this long after its exposure (rounded up to the world's states), s", minimum=0.0, maximum=0.2, read_only=True),
    ParamSpec("pixel_noise_std", float, 2.0, "Gaussian noise on each pixel's intensity, levels of 255", minimum=0.0, maximum=50.0),
    ParamSpec("occluded_link", str, "", "a link whose markers are hidden (something between it and the camera) during occlusion_s; empty: none"),
    ParamSpec("occlusion_s", float, [], "when occluded_link is hidden: [from_s, duration_s] of the world's time (empty: all along)", length=2, allow_empty=True),
    ParamSpec("seed", int, 0, "random seed of the pixel noise; -1 draws one from the OS", minimum=-1),
    ParamSpec("every_state", bool, True, f"where the world waits, take every {spec.TRUE_STATE.topic} state in turn (the loop's sensor: each is a tick); false: only the latest, a frame dropped when the camera cannot keep up (beside the encoder in the paced world, which does not wait for it)", read_only=True),
    world_waits_spec(f"on the sim's clock: every {spec.IMAGE.topic} frame is kept for the vision (each is a tick's reading)"),
)
VISION_NODE_PARAMS: tuple[ParamSpec, ...] = (
    URDF,
    ParamSpec("block", str, "vision", "the vision block it runs (fixed at start)", choices=tuple(BLOCKS["vision_node"]), read_only=True),
    *CAMERA_PLACEMENT_PARAMS,
    *VISION_PARAMS,
    ParamSpec("seed", int, 0, "random seed of the calibration error; -1 draws one from the OS", minimum=-1),
    world_waits_spec(f"on the sim's clock: {spec.CAMERA_READING.topic} is transient local, as the readings are"),
)
# fmt: on


# The controller: the law and its gains, the filter and observer, feedforward, the arm model, limits, the clock.
# fmt: off
PID_CONTROLLER_PARAMS: tuple[ParamSpec, ...] = (
    URDF,
    ParamSpec("controller_type", str, "lqr", "control law behind the node: pid (the gains below), lqr (gains from a discrete Riccati design with lqr_q and lqr_r), or a law of your own: an installed plugin's name, package.module:Class or path/to/file.py:Class (docs/own-controller.md), chosen at start; its declared parameters are law.NAME"),
    ParamSpec("stop_law", str, "lqr", "under a law of your own: the built-in law (with the gains here) that brings the arm to rest if it raises, returns a non-finite torque or the wrong shape, overruns law_budget_s or lets the arm run away from its reference (law_error_max_rad)", choices=("pid", "lqr")),
    ParamSpec("law_budget_s", float, 0.005, "under a law of your own: the time its update may take per tick, s: its thread's CPU time where the world waits for it (sim time, the paced world), else wall time less what the host took from its thread; longer on 3 ticks running, or blocked (0.5 s of wall time where the world waits), is a fault (controlled stop); at most 0.05 s, the drive's default command timeout: a law blocked longer starves the drive into braking before the controlled stop", **POSITIVE, maximum=0.05, **SAFETY),
    ParamSpec("law_error_max_rad", float, 0.5, "under a law of your own: how far the arm may run away from the reference on any joint (moving away, pushed on by the law's torque beyond gravity; the way a stop at stop_deceleration would still go counted), rad; further is a fault (controlled stop): an unstable law swings the arm while it returns finite torques in time; 0: no check; at most 1 rad (the joints' bands are 0.1)", minimum=0.0, maximum=1.0, **SAFETY),
    ParamSpec("lqr_q", float, [10000.0, 10000.0, 1.0], "LQR state weights on [∫error, error, velocity error]", length=3, minimum=0.0),
    ParamSpec("lqr_r", float, [10.0], "LQR weight on the feedback torque: one value for every joint (scaled by reference_inertia), or one per joint (as tune designs each joint's bandwidth)", per_joint=True, **POSITIVE),
    ParamSpec("reference_inertia", float, 1.0 / 12.0, "the joint inertia lqr_r and the Kalman filter's torque noise figures are for, kg·m² (the reference arm's); on each joint the LQR's torque weight is lqr_r·(this / its inertia at design_position)² and the observer's torque σs are scaled by (its inertia / this), so every joint gets the same closed-loop poles and the same observer (0: the values as they are on every joint)", minimum=0.0, read_only=True),
    ParamSpec("rated_payload_kg", float, 0.0, "the most the arm may carry on its last link that the model does not know (its rated payload), kg, its centre within 0.1 m of that link's origin: the LQR's gains are designed for each joint's inertia with such a load at its worst place (at most 4× the arm's own), and while readings disagree with the filter, the disturbance observer may follow, on each joint, as fast a change as such a load's gravity torque there (at design_position) within a second (0: none allowed for). On the sim's clock only: so fast an observer and gains leave no delay margin for a delay the stamps do not show (min_delay_margin_periods is checked without the observer's allowance)", minimum=0.0, read_only=True),
    ParamSpec("model_drive_lag_s", float, 0.0, "the drive's first-order lag time constant, s, as identify finds it (0: none): each command is what moves the torque the drive applies to the law's, so the law, the filter and the feedforward see a drive without lag (stable for a lag up to twice the drive's)", minimum=0.0, read_only=True),
    ParamSpec("estimator", str, "kalman", "state estimate the law acts on: the raw reading, or a Kalman filter on position and velocity with the applied torque as input", choices=("none", "kalman")),
    ParamSpec("kalman_position_noise_std", float, 0.005, "Kalman filter: encoder position noise σ, rad", **POSITIVE),
    ParamSpec("kalman_velocity_noise_std", float, 0.02, "Kalman filter: encoder velocity noise σ, rad/s", **POSITIVE),
    ParamSpec("kalman_acceleration_noise_std", float, 0.005, "Kalman filter: unmodelled acceleration σ, rad/s², while the readings agree with the filter: small, so that it trusts the arm model and averages the sensor noise away over about a second. On the sim's clock only: on the wall clock the filter runs at its mismatch settings and takes no jumps", **POSITIVE),
    ParamSpec("disturbance_observer", bool, True, "Kalman filter: also estimate an unknown external torque on each joint (a push, a load, what the arm model gets wrong) and subtract it from the command, within torque_max (a disturbance observer); no effect with estimator none"),
    ParamSpec("inertia_adaptation", bool, True, "disturbance observer, on the sim's clock only: estimate the inertia each joint has beyond the arm model (a geared motor's rotor, armature) from what the observer sees while the readings disagree with the filter, and add it to the model and the gains (each joint's scaled with its design inertia); an arm as heavy as its model is never touched", read_only=True),
    ParamSpec("kalman_disturbance_noise_std", float, 0.0001, "disturbance observer: how fast the external torque may change between jumps (σ of its random walk), N·m/√s, while the readings agree with the filter; a push is followed as a jump (kalman_disturbance_jump_sigma)", **POSITIVE),
    ParamSpec("kalman_disturbance_jump_sigma", float, 5.0, "disturbance observer: a reading this many σ from the filter's prediction, among readings that agree with it, is taken as a sudden external torque (a push), which the observer follows within a period or two; 0: never. On the sim's clock only (on the wall clock a push begins anywhere inside a period)", minimum=0.0),
    ParamSpec("kalman_mismatch_acceleration_noise_std", float, 2.0, "Kalman filter: unmodelled acceleration σ, rad/s², it moves to while its readings disagree with it (an arm unlike its model, readings later than their stamps), to follow the readings rather than the model", **POSITIVE),
    ParamSpec("kalman_command_timing_uncertainty_s", float, 0.01, "Kalman filter, on the wall clock only: how uncertain the instant is from which a new command acts on the arm (the command path's latency and jitter), s; a change of command Δτ leaves the velocity that much less certain (Δτ·this/inertia). On the sim's clock each command acts from its tick: 0 there", minimum=0.0, maximum=0.1),
    ParamSpec("kalman_mismatch_disturbance_noise_std", float, 0.3, "disturbance observer: the external torque's σ, N·m/√s, it moves to while the readings disagree with the filter", **POSITIVE),
    ParamSpec("control_rate_hz", float, 100.0, "control loop rate, Hz: the loop's one rate, the simulator's control_rate_hz too (a parameter file sets it on either node, and run gives both the value; two different values are refused)", minimum=10.0, maximum=1000.0),
    ParamSpec("trigger", str, "measurement", "what starts a control step: a timer at control_rate_hz (the tutorial's way) or each new sensor reading (read-update-write, no phase delay; a timer still runs the watchdog)", choices=("timer", "measurement")),
    ParamSpec("kp", float, [50.0], "proportional gain, N·m/rad: one per joint, as given; one value on a chain of joints is for a joint of reference_inertia and scaled by each joint's inertia at design_position over it (the same closed loop on every joint); so are ki and kd", per_joint=True, minimum=0.0),
    ParamSpec("ki", float, [10.0], "integral gain, N·m/(rad·s)", per_joint=True, minimum=0.0),
    ParamSpec("kd", float, [5.0], "derivative gain, N·m·s/rad", per_joint=True, minimum=0.0),
    ParamSpec("min_delay_margin_periods", int, 1, "control periods of delay margin the built-in law's gains (pid or lqr; under a law of your own, stop_law's) must leave every joint, else they are refused: fewer, and the loop is unstable or becomes so with that much delay (0: no check, for an experiment that runs an unstable loop on purpose)", minimum=0, **SAFETY),
    ParamSpec("integral_limit", float, [10.0], "clamp on the integral of the error, rad·s (anti_windup clamp)", per_joint=True, minimum=0.0),
    ParamSpec("anti_windup", str, "conditional_integration", "anti-windup mode", choices=enum_values(AntiWindup)),
    ParamSpec("back_calculation_time_s", float, 0.1, "tracking time constant of back-calculation anti-windup, s", **POSITIVE),
    ParamSpec("derivative_source", str, "velocity_error", "what the D term differentiates", choices=enum_values(DerivativeSource)),
    ParamSpec("derivative_filter_time_s", float, 0.0, "first-order filter on the D term, s (0 = off)", minimum=0.0),
    ParamSpec("feedforward", str, "full", "model feedforward from the arm model (the URDF, or the model_* values below)", choices=enum_values(FeedforwardMode)),
    ParamSpec("feedback_decoupling", bool, True, "on a chain of joints, pass the feedback torques through M(q)·diag(M(q))⁻¹ (the arm model's mass matrix), so each joint gets the acceleration its own gains ask for whatever the others do, as computed-torque control does; no effect on one joint or without the arm model"),
    # The arm model every model-based part uses (feedforward, Kalman prediction, LQR design, latency
    # compensation, the controlled stop): the URDF's unless these say otherwise (`robot-controller identify`
    # writes them). Any one set: tau = I·a + b·v + f_c·sign(v) + G·cos(q) per joint, the rest from the URDF.
    *arm_model_specs(),
    torque_max_spec("output limit"),
    ParamSpec("design_position", float, [], "the pose the LQR gains and the delay margin are designed at (each joint's inertia there), rad per joint (empty: every joint at 0, or the nearest end of its range); --robot sets the robot's home pose", per_joint=True, allow_empty=True, read_only=True),
    ParamSpec("slew_rate_limit", float, 0.0, "maximum rate of change of the command, N·m/s (0 = off)", minimum=0.0),
    ParamSpec("reference_extrapolation", bool, True, "evaluate the latest reference at the tick time with its velocity and acceleration"),
    ParamSpec("latency_compensation", bool, True, "advance the measurement from its stamp to the tick time with its velocity"),
    ParamSpec("camera_wait_s", float, 0.0, f"on sim time, how long (wall s) a tick waits for a camera's {spec.CAMERA_READING.topic} it knows is due beside the encoder's (--sensing both: run sets it, so a run fuses each frame at the same tick every time); 0: never waits (the paced world keeps pace with the wall clock and does not wait for a second sensor)", minimum=0.0, maximum=1.0, read_only=True),
    ParamSpec("camera_period_s", float, 0.0, "the period of a camera's frames beside the encoder (run sets it from camera_node's rate): when its next reading is due, on sim time", minimum=0.0, maximum=1.0, read_only=True),
    ParamSpec("camera_latency_s", float, 0.0, "how long after its exposure a camera beside the encoder publishes each frame (run sets it from camera_node's latency_s): when its next reading is due, on sim time", minimum=0.0, maximum=1.0, read_only=True),
    ParamSpec("watchdog_periods", int, 5, "control periods without valid sensor data before a controlled stop on the arm model's estimate (category 2); at most 20 (what a 1 kHz loop needs over 100 Hz readings; at 100 Hz the law acts on its last reading for 0.2 s)", minimum=1, maximum=20, **SAFETY),
    ParamSpec("sensor_timeout_s", float, 1.0, "readings missing this long end the controlled stop: no command, the drive's brake holds (category 1), s; at most 1 s: the stop runs open loop on the arm model that long", **POSITIVE, maximum=1.0, **SAFETY),
    ParamSpec("max_reading_age_s", float, 0.1, "a reading older than this when it arrives (or stamped this far in the future) is dropped and does not count as a sign of life, s; at most 0.2 s, the watchdog's longest window at 100 Hz", **POSITIVE, maximum=0.2, **SAFETY),
    ParamSpec("stop_deceleration", float, 20.0, "deceleration of a controlled stop (sensor or planner lost), rad/s²; at least 1: from 3 rad/s a stop of 3 s and 4.5 rad", minimum=1.0, **SAFETY),
    ParamSpec("reacquire_acceleration", float, 20.0, "acceleration limit of the blend from where the arm is back onto the trajectory after a fault, rad/s²; at most 100 (the reference arm's torque gives about 90: faster, the blend saturates)", **POSITIVE, maximum=100.0, **SAFETY),
    ParamSpec("log_period_s", float, 1.0, "period of the target/actual/error/torque log line, s", **POSITIVE),
    ParamSpec("diagnostics_period_s", float, 1.0, f"period of the loop-health report on {spec.DIAGNOSTICS.topic}, s", **POSITIVE),
    world_waits_spec("compute on each measurement once the due reference is in (on the sim's clock), not on a timer"),
)
# fmt: on


# The planner: the reference's shape and the feasibility check against the arm model.
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
    ParamSpec("start_position", float, [], "where the arm stands when the motion starts, rad (m), one per joint: the motion is blended in from there within the limits; empty: from the motion's own start (a run on a robot reads it from the robot)", per_joint=True, allow_empty=True),
    ParamSpec("velocity_envelope", str, "", "the robot's own speed limits near its position limits, which a trajectory keeps within too (by velocity_share): fr3 (libfranka's, the FR3's); empty: none (a run on a Franka takes fr3)", choices=("", "fr3")),
    ParamSpec("velocity_share", float, 1.0, "share of each joint's URDF velocity limit a trajectory may reach (beyond it: as feasibility says); a run on a robot takes 0.8, inside its guard's 85 %", minimum=0.1, maximum=1.0),
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


NODES = ("simulator", "motor_node", "sensor_node", "pid_controller", "trajectory_planner", "camera_node", "vision_node")
# Parameters rclpy declares on every node by itself.
ROS_BUILTIN = ("use_sim_time", "start_type_description_service")
# Parameters a node declares to report something it works out (read-only in effect); a parameter file
# that holds them (`robot-controller param dump`) is read without them.
REPORTED = ("law_in_force",)
# Parameters of the whole loop that several nodes declare: one value for all of them. A parameter file names them
# on any of these nodes (or under /**); the launcher hands the value to each (``files.load_stack``), and the
# whole-configuration check refuses two nodes that disagree (``consistency``).
LOOP_WIDE: dict[str, tuple[str, ...]] = {
    "control_rate_hz": ("simulator", "pid_controller"),
    **{p.name: ("camera_node", "sensor_node", "vision_node") for p in CAMERA_PLACEMENT_PARAMS},
}

SCHEMA: dict[str, tuple[ParamSpec, ...]] = {
    "simulator": SIMULATOR_PARAMS,
    "motor_node": MOTOR_NODE_PARAMS,
    "sensor_node": SENSOR_NODE_PARAMS,
    "pid_controller": PID_CONTROLLER_PARAMS,
    "trajectory_planner": TRAJECTORY_PLANNER_PARAMS,
    "camera_node": CAMERA_NODE_PARAMS,
    "vision_node": VISION_NODE_PARAMS,
}


def spec_of(node: str, name: str) -> ParamSpec:
    """``node``'s parameter ``name``; ``KeyError`` if it has none."""
    for param in SCHEMA[node]:
        if param.name == name:
            return param
    raise KeyError(f"{node}.{name}")


def has(node: str, name: str) -> bool:
    return any(spec.name == name for spec in SCHEMA[node])


def defaults() -> dict[str, dict]:
    """Every node's default values (the reference scenario with the default controller)."""
    return {node: {spec.name: spec.default_value() for spec in specs} for node, specs in SCHEMA.items()}


def node_defaults(node: str) -> dict:
    """``node``'s default values: the one set the core's configs are made from (``parameters.builders``)."""
    return {spec.name: spec.default_value() for spec in SCHEMA[node]}
