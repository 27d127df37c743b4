"""The simulator's parameters: the arm and its physics, the wall clock or the sim's, the brakes,
the scheduled disturbance."""

from __future__ import annotations

from robot_controller.blocks import spec
from robot_controller.parameters.schema.shared import POSITIVE, SAFETY, URDF, world_waits_spec
from robot_controller.parameters.spec import ParamSpec

#: Sim seconds the simulator runs past a sim-time run's duration (its ``lockstep_end_s``): the nodes may stop then.
LOCKSTEP_END_MARGIN_S = 0.5

# One line per parameter: the schema reads as a table.
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
