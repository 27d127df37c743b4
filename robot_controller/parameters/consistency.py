"""The whole configuration checked before anything starts: each value on its own (the schema), then the five nodes'
values against each other and against the arm the URDFs describe; a problem is a ``ConfigError`` naming the node, the
key and what is wrong. The nodes check their own values again on every change; the cross-node rules live here."""

from __future__ import annotations

import copy
from typing import TYPE_CHECKING

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.errors import ConfigError
from robot_controller.core.laws import law_parameters
from robot_controller.core.model import joint_limits, urdf_velocity_limits
from robot_controller.core.model.plant_variation import PlantVariation
from robot_controller.core.model.velocity_envelope import ENVELOPES, position_range
from robot_controller.parameters import files, law_params
from robot_controller.parameters.builders import ARM_MODEL_KEYS, arm_model, given
from robot_controller.parameters.torque_limits import torque_limit

if TYPE_CHECKING:  # MuJoCo and the trajectories: imported when used
    from robot_controller.core.reference import Plan

# The watchdog must outlast this many reading periods: a shorter window trips between two readings.
WATCHDOG_MIN_READINGS = 2
# Drive and motor timeouts must outlast this many control periods.
TIMEOUT_MIN_PERIODS = 2


def check_stack(params: cfg.Params) -> None:
    """Raise ``ConfigError`` for the first problem found."""
    for node in cfg.NODES:
        for spec in cfg.SCHEMA[node]:
            try:
                spec.validate(params[node][spec.name])
            except ConfigError as exc:
                raise ConfigError(f"{node}: {exc}") from None
    law_parameters.check_values(params["pid_controller"])  # the law controller_type names, and its law.* values
    arms = {node: _arm(node, params[node]["urdf_path"]) for node in ("simulator", "motor_node", "pid_controller")}
    names = arms["simulator"][0]
    for node, (other, _, _) in arms.items():
        if other != names:
            raise ConfigError(f"joint names differ: simulator's URDF has {names}, {node}'s has {other}")
    joint_count = len(names)
    _check_per_joint(params, joint_count)
    PlantVariation.from_params(params["simulator"], "simulator: ")  # payload or payload_kg, not both
    _check_rates(params)
    files.one_value_for_the_loop(params, [("", params)])  # as load_stack gives them: one value each
    _check_limits(params, arms["simulator"])
    _check_planner_matches(params, joint_count)
    _check_controller(params, joint_count)
    trajectory_plan(params)  # refused: a ConfigError


def _arm(node: str, urdf_path: str) -> tuple[list[str], np.ndarray, np.ndarray]:
    """Joint names, effort limits and position ranges of a node's URDF."""
    from robot_controller.core.model import effort_limits, joint_names, load_model

    try:
        model = load_model(resources.resolve_urdf(urdf_path))
    except Exception as exc:  # noqa: BLE001 - MuJoCo's and the file system's errors alike
        raise ConfigError(f"{node}: urdf_path {urdf_path or '(reference arm)'!r}: {exc}") from None
    count = len(joint_names(model))
    ranges = np.where(model.jnt_limited[:count, None].astype(bool), model.jnt_range[:count], [[-np.inf, np.inf]])
    return joint_names(model), effort_limits(model), ranges


def _check_per_joint(params: cfg.Params, joint_count: int) -> None:
    planner = params["trajectory_planner"]
    if planner["joint_count"] != joint_count:
        count = planner["joint_count"]
        raise ConfigError(f"trajectory_planner: joint_count {count} but the URDF has {joint_count} joint(s)")
    for node in cfg.NODES:
        for spec in law_params.node_specs(node, params[node]):
            if spec.per_joint and spec.name not in params[node]:
                continue  # a law's parameter left to its default (the law builds with it)
            if spec.per_joint and not (spec.allow_empty and not np.size(params[node][spec.name])):
                try:
                    cfg.per_joint(spec.name, params[node][spec.name], joint_count)
                except ConfigError as exc:
                    raise ConfigError(f"{node}: {exc}") from None


def _check_rates(params: cfg.Params) -> None:
    from robot_controller.core.model import steps_per_period

    sim, sensor = params["simulator"], params["sensor_node"]
    ctrl, motor = params["pid_controller"], params["motor_node"]
    physics_dt = 1.0 / sim["physics_rate_hz"]
    try:
        steps_per_period(physics_dt, 1.0 / sim["publish_rate_hz"])
    except Exception as exc:  # noqa: BLE001 - TimingError
        raise ConfigError(f"simulator: publish_rate_hz {sim['publish_rate_hz']:g}: {exc}") from None
    if sensor["rate_hz"] > sim["publish_rate_hz"] + 1e-9:
        publishes = f"the simulator publishes ({sim['publish_rate_hz']:g} Hz)"
        raise ConfigError(f"sensor_node: rate_hz {sensor['rate_hz']:g} is faster than {publishes}")
    control_period_s = 1.0 / ctrl["control_rate_hz"]
    watchdog_s = ctrl["watchdog_periods"] * control_period_s
    reading_period_s = 1.0 / sensor["rate_hz"]
    if watchdog_s < WATCHDOG_MIN_READINGS * reading_period_s - 1e-9:
        raise ConfigError(
            f"pid_controller: watchdog_periods {ctrl['watchdog_periods']} at control_rate_hz "
            f"{ctrl['control_rate_hz']:g} is a {watchdog_s * 1e3:g} ms window, shorter than "
            f"{WATCHDOG_MIN_READINGS} readings at {sensor['rate_hz']:g} Hz: raise watchdog_periods to at least "
            f"{int(np.ceil(WATCHDOG_MIN_READINGS * reading_period_s / control_period_s - 1e-9))}"
        )
    for node, key, value in (
        ("motor_node", "command_timeout_s", motor["command_timeout_s"]),
        ("simulator", "drive_timeout_s", sim["drive_timeout_s"]),
    ):
        if value < TIMEOUT_MIN_PERIODS * control_period_s - 1e-9:
            raise ConfigError(
                f"{node}: {key} {value:g} s is shorter than {TIMEOUT_MIN_PERIODS} control periods "
                f"({TIMEOUT_MIN_PERIODS * control_period_s:g} s)"
            )
    if cfg.world_waits(sim) or cfg.world_waits(ctrl):
        try:
            steps_per_period(physics_dt, control_period_s)
        except Exception as exc:  # noqa: BLE001 - TimingError
            raise ConfigError(f"pid_controller: control_rate_hz {ctrl['control_rate_hz']:g}: {exc}") from None


def _check_limits(params: cfg.Params, arm: tuple[list[str], np.ndarray, np.ndarray]) -> None:
    names, effort_limit, ranges = arm
    n = len(names)
    for node in ("motor_node", "pid_controller"):
        torque_max = torque_limit(params[node], n)
        if np.any(torque_max > effort_limit):
            raise ConfigError(
                f"{node}: torque_max {torque_max.tolist()} N·m exceeds the URDF's effort limit "
                f"{effort_limit.tolist()} N·m (it may lower the limit, never raise it)"
            )
    initial = cfg.per_joint("initial_position", params["simulator"]["initial_position"], n)
    if np.any((initial < ranges[:, 0]) | (initial > ranges[:, 1])):
        raise ConfigError(f"simulator: initial_position {initial.tolist()} rad is outside the joint limits")


def _check_controller(params: cfg.Params, joint_count: int) -> None:
    """The controller builds: its arm model (the URDF's, or its ``model_*`` values) and its law
    designs (an LQR that does not stabilise is refused here), leaving every joint its delay margin."""
    from robot_controller.core.controller import JointController, check_delay_margin

    ctrl = params["pid_controller"]
    try:
        config, dynamics = cfg.controller_config(ctrl, joint_count), arm_model(ctrl)
        # The margin of the gains the controller designed: one design, not two.
        controller = JointController(config, joint_count, dynamics)
        check_delay_margin(config, dynamics, joint_count, gains=controller.stop_law.pid.config)
    except ConfigError as exc:
        raise ConfigError(f"pid_controller: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - a solver's error is a refusal, not a crash
        raise ConfigError(f"pid_controller: {type(exc).__name__}: {exc}") from None


def _check_planner_matches(params: cfg.Params, joint_count: int) -> None:
    """The planner checks its trajectory against the arm the controller models and the actuator that will
    follow it: the motor's ``torque_max``, the controller's URDF and ``model_*`` values."""
    planner, motor, ctrl = params["trajectory_planner"], params["motor_node"], params["pid_controller"]
    planned = torque_limit(planner, joint_count)
    actual = torque_limit(motor, joint_count)
    if not np.array_equal(planned, actual):
        raise ConfigError(
            f"trajectory_planner: torque_max {planned.tolist()} N·m differs from motor_node's "
            f"{actual.tolist()} N·m, the limit its trajectory is checked against: set both "
            "(or set it once under /**)"
        )
    mine, theirs = (resources.resolve_urdf(path).resolve() for path in (planner["urdf_path"], ctrl["urdf_path"]))
    if mine != theirs:
        raise ConfigError(
            f"trajectory_planner: urdf_path {planner['urdf_path'] or '(reference arm)'!r} differs from "
            f"pid_controller's {ctrl['urdf_path'] or '(reference arm)'!r}"
        )

    for key in ARM_MODEL_KEYS:  # empty: the controller's (``run`` passes it on); set: the controller's too
        if not given(planner[key]):
            continue
        if key == "model_payload":
            if given(ctrl[key]) and np.array_equal(planner[key], ctrl[key]):
                continue
        elif given(ctrl[key]) and np.array_equal(
            cfg.per_joint(key, planner[key], joint_count), cfg.per_joint(key, ctrl[key], joint_count)
        ):
            continue
        theirs = ctrl[key] if given(ctrl[key]) else "[] (the URDF's)"
        raise ConfigError(
            f"trajectory_planner: {key} {planner[key]} differs from pid_controller's {theirs}, the arm model "
            "its trajectory is checked against: leave it empty (run passes the controller's on) or set both "
            "(or set it once under /**)"
        )


def with_controller_model(params: cfg.Params) -> cfg.Params:
    """The same parameters with each ``model_*`` the planner leaves empty taken from pid_controller's."""
    out = cfg.merge(params, {})
    planner, ctrl = out["trajectory_planner"], out["pid_controller"]
    for key in ARM_MODEL_KEYS:
        if planner.get(key) is None or np.size(planner[key]) == 0:
            planner[key] = copy.deepcopy(ctrl[key])  # not the same list: YAML would write an alias, which rcl refuses
    return out


def trajectory_plan(params: cfg.Params) -> Plan:
    """The trajectory the run follows: the planner's, checked against the controller's arm model (the ROS planner's
    too: :func:`check_stack` refuses a difference) and slowed, refused (``ConfigError``) or left as its
    ``feasibility`` says."""
    from robot_controller.core.reference import make_trajectory, plan_trajectory

    planner = params["trajectory_planner"]
    dynamics, limits = arm_model(params["pid_controller"]), joint_limits(resources.resolve_urdf(planner["urdf_path"]))
    try:
        trajectory = make_trajectory(planner["mode"], **cfg.trajectory_kwargs(planner))
        return plan_trajectory(
            trajectory,
            dynamics,
            torque_limit(planner, len(dynamics.joint_names)),
            margin=planner["feasibility_margin"],
            policy=planner["feasibility"],
            what=planner["mode"],
            joint_names=dynamics.joint_names,
            velocity_limit=planner["velocity_share"]
            * urdf_velocity_limits(resources.resolve_urdf(planner["urdf_path"]), dynamics.joint_names),
            position_range=position_range(limits, planner),  # as the planner checks every live change
            envelope=ENVELOPES.get(planner["velocity_envelope"]),
        )
    except ConfigError as exc:
        raise ConfigError(f"trajectory_planner: {exc}") from None
