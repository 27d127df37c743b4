"""The run ``robot-controller identify`` fits to (the planner's chirp, sweeping ``start_hz`` to
``end_hz`` over the run) and the samples the fit leaves out (brakes held, a push, the torque saturated)."""

from __future__ import annotations

from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.parameters.torque_limits import torque_limit as node_torque_limit

# The excitation: a chirp within the reference sine's range and speed (4× the arm's inertia follows it in 10 N·m).
AMPLITUDE_RAD = 0.8
START_HZ = 0.1
END_HZ = 0.5


def excitation_params(
    params: cfg.Params,
    duration_s: float,
    *,
    amplitude_rad: float = AMPLITUDE_RAD,
    start_hz: float = START_HZ,
    end_hz: float = END_HZ,
) -> cfg.Params:
    """``params`` with the planner in chirp mode, one sweep over ``duration_s``; on a chain of joints at the planner's
    own amplitudes (each within its joint's range about the robot's home pose), on one joint ``amplitude_rad``."""
    planner = params["trajectory_planner"]
    amplitude = [float(amplitude_rad)] if planner["joint_count"] == 1 else list(planner["amplitude"])
    chirp = {"mode": "chirp", "amplitude": amplitude, "frequency_hz": float(start_hz)}
    chirp.update(end_frequency_hz=float(end_hz), sweep_time_s=float(duration_s))
    return cfg.merge(params, {"trajectory_planner": chirp})


def _step_at(times_s: np.ndarray, event_times_s: np.ndarray, values: np.ndarray, joint_count: int) -> np.ndarray:
    """The latest of ``values`` (a row per event, a column per joint) at each of ``times_s``, as booleans (0 before)."""
    out = np.zeros((len(times_s), joint_count), dtype=bool)
    if len(event_times_s) == 0:
        return out
    order = np.argsort(event_times_s, kind="stable")
    index = np.searchsorted(event_times_s[order], times_s, side="right") - 1
    known = index >= 0
    out[known] = np.asarray(values)[order][index[known]] != 0
    return out


def held_or_pushed(recording: Any) -> np.ndarray:
    """Per true-state sample and joint: a brake engaged or a disturbance acting (not in the model, so left out)."""
    t, n = recording.true_time_s, recording.joint_count
    mask = _step_at(t, recording.brakes_time_s, recording.brakes, n)
    if len(getattr(recording, "disturbance_time_s", ())):
        mask |= _step_at(t, recording.disturbance_time_s, recording.disturbance, n)
    return mask


def fit_inputs(params: cfg.Params, recording: Any, joint_count: int) -> tuple[tuple, dict[str, np.ndarray]]:
    """What a fit takes from a run: the TRUE time, position, velocity and applied torque, and what to leave out."""
    motion = (recording.true_time_s, recording.true_position, recording.true_velocity, recording.true_effort)
    return motion, {"effort_limit": torque_limit(params, joint_count), "braked": held_or_pushed(recording)}


def torque_limit(params: cfg.Params, joint_count: int) -> np.ndarray:
    """The torque a recorded effort saturates at: the least of both ``torque_max`` and the arm's effort limit."""
    from robot_controller.core.model import effort_limits, load_model

    limit = effort_limits(load_model(resources.resolve_urdf(params["simulator"]["urdf_path"])))
    for node in ("motor_node", "pid_controller"):
        limit = np.minimum(limit, node_torque_limit(params[node], joint_count))
    return limit


def joint_names(params: cfg.Params) -> list[str]:
    """The simulated arm's joints, in the URDF's order."""
    from robot_controller.core.model import joint_names, load_model

    return joint_names(load_model(resources.resolve_urdf(params["simulator"]["urdf_path"])))
