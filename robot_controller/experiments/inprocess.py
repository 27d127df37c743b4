"""The in-process loop (no ROS), built from the parameters the ROS graph uses."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.blocks.block import Lines, make_block
from robot_controller.blocks.wiring import LoopResult, run_loop
from robot_controller.blocks.world import World
from robot_controller.core.controller import JointController
from robot_controller.core.model import MujocoPlant, PlantVariation
from robot_controller.parameters import consistency
from robot_controller.parameters.builders import arm_model

#: s of wall time a law's call may run before it is abandoned: the loop waits for the law as the world on sim time does,
#: so only a law that blocks (sleeps, loops, deadlocks) is abandoned, never one the host kept from a CPU a moment.
ABANDON_S = 1.0


@dataclass(frozen=True)
class Disturbance:
    """An external torque on the arm from a set physics time: the world starts it with the first physics steps at or
    after ``start_s``, as the simulator's ``disturbance_*`` parameters schedule it."""

    torque_nm: np.ndarray  #: N·m per joint
    start_s: float  #: s of physics time
    duration_s: float  #: s


def simulate(params: cfg.Params, *, duration_s: float, **options: Any) -> LoopResult:
    """``duration_s`` seconds of the loop from ``params``: :func:`prepare`'s loop (the same options), run."""
    return prepare(params, duration_s=duration_s, **options)()


def prepare(
    params: cfg.Params,
    *,
    duration_s: float,
    seed: int = 0,
    measurement_delay_s: float = 0.0,
    delay_unstamped: bool = False,
    disturbance: Disturbance | None = None,
    on_warning: Callable[[str], None] | None = None,
    actuator_gain: float = 1.0,
) -> Callable[[], LoopResult]:
    """The loop from ``params``, built (URDF compiled, trajectory planned, gains designed): calling it runs
    ``duration_s`` s of :func:`run_loop`, the loop alone (what the bench times).

    :param disturbance: an external torque on a schedule, in place of the simulator's ``disturbance_*``
    :param on_warning: receives the planner's one-line warning (a trajectory slowed, or run as it is)
    :param actuator_gain: the drive applies this many times the command (before its torque limit)
    :raises ConfigError: the planner's one line, when it refuses the trajectory
    """
    sim, motor, sensor = params["simulator"], params["motor_node"], params["sensor_node"]
    ctrl, planner = params["pid_controller"], params["trajectory_planner"]
    plan = consistency.trajectory_plan(params)  # refused: the planner's one line, before anything is built
    if plan.warning is not None and on_warning is not None:
        on_warning(plan.warning)
    variation = PlantVariation.from_params(sim, "simulator.")  # the simulator node's plant, the same way
    plant = MujocoPlant(resources.resolve_urdf(sim["urdf_path"]), 1.0 / sim["physics_rate_hz"], variation=variation)
    n = len(plant.joint_names)
    plant.reset(cfg.per_joint("initial_position", sim["initial_position"], n))
    if disturbance is not None:  # the world schedules it, as the simulator node's parameters would
        sim = dict(
            sim,
            disturbance_torque_nm=[float(x) for x in np.atleast_1d(disturbance.torque_nm)],
            disturbance_start_s=disturbance.start_s,
            disturbance_duration_s=disturbance.duration_s,
        )
    world = World(sim, Lines(), world_waits=True, plant=plant)
    dynamics = arm_model(ctrl)  # the URDF's, or the controller's model_* values over it
    controller_config = cfg.controller_config({**ctrl, cfg.WORLD_WAITS: True}, n)  # each command acts from its tick
    controller = contained_controller(controller_config, n, dynamics)
    # The graph's sensor and drive, as their nodes' configuration chooses them; the loop's clock waits for each.
    if sensor["block"] == "vision":  # a camera's (``--sensing camera``): the camera and the vision chained
        from robot_controller.blocks.camera_chain import CameraChain

        camera = dict(params["camera_node"], seed=seed)
        sensor_block = CameraChain(camera, dict(sensor, seed=seed), Lines(), world_waits=True)
    else:
        sensor_block = make_block("sensor_node", dict(sensor, seed=seed), Lines(), world_waits=True)
    drive_block = make_block("motor_node", motor, Lines(), world_waits=True)
    planner_params = consistency.with_controller_model(params)["trajectory_planner"]  # as ``run`` gives them
    planner_block = make_block("trajectory_planner", planner_params, Lines(), world_waits=True)
    planner_block.start()
    return partial(
        run_loop,
        world=world,
        controller=controller,
        sensor=sensor_block,
        drive=drive_block,
        planner=planner_block,
        duration_s=duration_s,
        control_period_s=controller_config.control_period_s,
        planner_period_s=1.0 / planner["publish_rate_hz"],
        measurement_delay_s=measurement_delay_s,
        delay_unstamped=delay_unstamped,
        command_gain=actuator_gain,
    )


def contained_controller(config, joint_count: int, dynamics) -> JointController:
    """The controller as the node builds it, a law of one's own contained alike (torque, slew, error band, each call
    on a thread of its own), its budget judged on its thread's CPU time: the loop runs at no wall rate, so a law is
    slow for what it computes, and a law that blocks is abandoned after :data:`ABANDON_S` of wall time, a fault
    whose controlled stop (category 2, then 1) ends the run's motion instead of hanging it."""
    controller = JointController(config, joint_count, dynamics, law_clock=time.thread_time)
    if controller.plugin is not None:
        controller.plugin.abandon_s = max(ABANDON_S, config.law_budget_s + config.control_period_s)
    return controller
