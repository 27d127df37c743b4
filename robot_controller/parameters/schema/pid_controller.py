"""The controller node's parameters: the law and its gains, the filter and observer, feedforward,
the arm model, the limits and the clock."""

from __future__ import annotations

from robot_controller.blocks import spec
from robot_controller.core.laws import FeedforwardMode
from robot_controller.core.laws.pid import AntiWindup, DerivativeSource
from robot_controller.parameters.schema.shared import (
    POSITIVE,
    SAFETY,
    URDF,
    arm_model_specs,
    enum_values,
    torque_max_spec,
    world_waits_spec,
)
from robot_controller.parameters.spec import ParamSpec

# One line per parameter: the schema reads as a table.
# fmt: off
PID_CONTROLLER_PARAMS: tuple[ParamSpec, ...] = (
    URDF,
    ParamSpec("controller_type", str, "lqr", "control law behind the node: pid (the gains below), lqr (gains from a discrete Riccati design with lqr_q and lqr_r), or a law of your own: an installed plugin's name, package.module:Class or path/to/file.py:Class (docs/own-controller.md), chosen at start; its declared parameters are law.NAME"),
    ParamSpec("stop_law", str, "lqr", "under a law of your own: the built-in law (with the gains here) that brings the arm to rest if it raises, returns a non-finite torque or the wrong shape, overruns law_budget_s or lets the arm run away from its reference (law_error_max_rad)", choices=("pid", "lqr")),
    ParamSpec("law_budget_s", float, 0.005, "under a law of your own: the time its update may take per tick, s: its thread's CPU time where the world waits for it (sim time, the paced world), else wall time less what the host took from its thread; longer on 3 ticks running, or blocked (0.5 s of wall time where the world waits), is a fault (controlled stop); at most 0.05 s, the drive's default command timeout: a law blocked longer starves the drive into braking before the controlled stop", **POSITIVE, maximum=0.05, **SAFETY),
    ParamSpec("law_error_max_rad", float, 0.5, "under a law of your own: how far the arm may run away from the reference on any joint (moving away, pushed on by the law's torque beyond gravity; the way a stop at stop_deceleration would still go counted), rad; further is a fault (controlled stop): an unstable law swings the arm while it returns finite torques in time; 0: no check; at most 1 rad (the joints' bands are 0.1)", minimum=0.0, maximum=1.0, **SAFETY),
    ParamSpec("lqr_q", float, [10000.0, 10000.0, 1.0], "LQR state weights on [∫error, error, velocity error]", length=3, minimum=0.0),
    ParamSpec("lqr_r", float, 10.0, "LQR weight on the feedback torque", **POSITIVE),
    ParamSpec("reference_inertia", float, 1.0 / 12.0, "the joint inertia lqr_r and the Kalman filter's torque noise figures are for, kg·m² (the reference arm's); on each joint the LQR's torque weight is lqr_r·(this / its inertia at design_position)² and the observer's torque σs are scaled by (its inertia / this), so every joint gets the same closed-loop poles and the same observer (0: the values as they are on every joint)", minimum=0.0, read_only=True),
    ParamSpec("rated_payload_kg", float, 0.0, "the most the arm may carry on its last link that the model does not know (its rated payload), kg, its centre within 0.1 m of that link's origin: the LQR's gains are designed for each joint's inertia with such a load at its worst place (at most 4× the arm's own), and while readings disagree with the filter, the disturbance observer may follow, on each joint, as fast a change as such a load's gravity torque there (at design_position) within a second (0: none allowed for). On the sim's clock only: so fast an observer and gains leave no delay margin for a delay the stamps do not show (min_delay_margin_periods is checked without the observer's allowance)", minimum=0.0, read_only=True),
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
