"""``run --sensing``: what the controller measures the arm with. ``encoders``: the sensor_node's encoder (the
reference). ``camera``: encoders swapped for a camera: ``camera_node`` renders the arm with markers on every link, and
``sensor_node`` runs the vision block, whose readings (late, slower, each joint with its σ) are the loop's, the
controller unchanged but for how long it waits for one. ``both``: the encoder's readings drive the loop and
``vision_node``'s are fused beside them by the controller's filter. A camera that cannot see what it must is refused
before anything starts, in one line naming it."""

from __future__ import annotations

import math

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.errors import ConfigError

#: the nodes each sensing adds to the graph's five
EXTRA_NODES = {"encoders": (), "camera": ("camera_node",), "both": ("camera_node", "vision_node")}
#: every node a sensing may add
CAMERA_NODES = ("camera_node", "vision_node")
#: how many of a camera's frame periods the controller's watchdog waits out (a lost frame is not a lost camera)
WATCHDOG_FRAMES = 2.0
#: s beyond a frame's period and latency a camera's reading may be old when it arrives (the render and the vision)
READING_AGE_MARGIN_S = 0.05
#: poses along the planned motion the camera must see every joint at
CHECKED_POSES = 24


#: wall s a sim-time tick waits for a camera's reading due beside the encoder's (``camera_wait_s``)
CAMERA_WAIT_S = 0.3


def with_sensing(params: cfg.Params, sensing: str, sim_time: bool = False) -> cfg.Params:
    """The parameters for ``sensing``; ``ConfigError`` for a camera that cannot close the loop."""
    if sensing == "encoders":
        return params
    out = cfg.merge(params, {})
    urdf = out["simulator"]["urdf_path"]
    ctrl = out["pid_controller"]
    if ctrl["estimator"] != "kalman":
        raise ConfigError(
            f"--sensing {sensing}: the camera's readings are late and carry no velocity; the controller's Kalman "
            "filter takes them (estimator kalman)"
        )
    camera = out["camera_node"]
    camera["urdf_path"] = urdf
    camera["seed"] = out["sensor_node"]["seed"]
    control_period_s = 1.0 / float(ctrl["control_rate_hz"])
    from robot_controller.blocks.camera import frame_ticks

    frame_period_s = frame_ticks(camera["camera_rate_hz"], control_period_s) * control_period_s
    late_s = frame_period_s + camera["latency_s"]
    watchdog = math.ceil((WATCHDOG_FRAMES * frame_period_s + camera["latency_s"]) / control_period_s)
    watchdog_max = cfg.spec_of("pid_controller", "watchdog_periods").maximum
    age_s = late_s + READING_AGE_MARGIN_S
    age_max = cfg.spec_of("pid_controller", "max_reading_age_s").maximum
    if watchdog > watchdog_max or age_s > age_max:
        raise ConfigError(
            f"camera_node.camera_rate_hz {camera['camera_rate_hz']:g} with latency_s {camera['latency_s']:g}: a "
            f"reading every {frame_period_s * 1e3:.0f} ms, {late_s * 1e3:.0f} ms late, is more than the controller "
            f"may coast on its model between readings ({watchdog_max} periods, readings at most {age_max:g} s old)"
        )
    if sensing == "camera":
        ctrl["trigger"] = "timer"  # on the wall clock the loop keeps its rate; the readings come a third as often
        ctrl["watchdog_periods"] = max(int(ctrl["watchdog_periods"]), watchdog)
        ctrl["max_reading_age_s"] = max(float(ctrl["max_reading_age_s"]), round(age_s, 3))
        out["sensor_node"]["block"] = "vision"
        out["sensor_node"]["urdf_path"] = urdf
    else:
        ctrl["max_reading_age_s"] = max(float(ctrl["max_reading_age_s"]), round(age_s, 3))
        ctrl["camera_wait_s"] = CAMERA_WAIT_S if sim_time else 0.0
        ctrl["camera_period_s"], ctrl["camera_latency_s"] = frame_period_s, camera["latency_s"]
        camera["every_state"] = sim_time  # beside the encoder in the paced world: the latest state, frames dropped
        out["vision_node"]["urdf_path"] = urdf
        out["vision_node"]["seed"] = out["sensor_node"]["seed"]
    check_view(out)
    return out


def check_view(params: cfg.Params) -> None:
    """Refuse a camera that does not see every joint at the poses of the planned motion (its start, and
    :data:`CHECKED_POSES` along it), naming the joints and where it stands."""
    from robot_controller.core.model import load_model
    from robot_controller.core.model.mujoco_model import joint_names
    from robot_controller.core.vision.joint_solver import observable_joints
    from robot_controller.core.vision.markers import place_markers
    from robot_controller.parameters.builders import camera_model

    urdf = resources.resolve_urdf(params["simulator"]["urdf_path"])
    model = load_model(urdf)
    camera = camera_model(params["camera_node"], model)
    layout = place_markers(model, camera)
    poses = planned_poses(params, len(joint_names(model)))
    seen = observable_joints(model, layout, camera, poses)
    if not all(seen):
        blind = [name for name, ok in zip(joint_names(model), seen, strict=False) if not ok]
        where = ", ".join(f"{x:g}" for x in camera.position_m)
        raise ConfigError(
            f"camera_node.camera_position_m [{where}]: the camera does not see {', '.join(blind)} along the planned "
            "motion (no marker it sees constrains them): move it, or point camera_target_m at the arm"
        )


def planned_poses(params: cfg.Params, joint_count: int) -> np.ndarray:
    """The arm's start and :data:`CHECKED_POSES` poses along the planned motion's first 10 s."""
    from robot_controller.parameters.consistency import trajectory_plan

    start = np.broadcast_to(np.asarray(params["simulator"]["initial_position"], dtype=float), (joint_count,))
    try:
        trajectory = trajectory_plan(params).trajectory
    except ConfigError:
        return start[None, :]  # the plan's own check says what is wrong with it
    times = np.linspace(0.0, 10.0, CHECKED_POSES)
    along = [np.broadcast_to(np.asarray(trajectory.sample(t)[0], dtype=float), (joint_count,)) for t in times]
    return np.vstack([start, *along])
