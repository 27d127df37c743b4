"""One contender at one seed, as ``compare`` runs it: the sine run, then the step run, on the real
graph on sim time or on the in-process loop, reduced to the compared figures (:data:`COMPARED`)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.core import metrics
from robot_controller.experiments.compare.contenders import Contender
from robot_controller.experiments.step import STEP_AFTER_S, check_step, run_and_score, step_params, step_response

COMPARED = {
    "sine": ("tracking_rms_rad", "tracking_max_rad", "start_tracking_max_rad"),
    "step": ("overshoot_pct", "settling_time_s", "rise_time_s", "peak_torque_nm", "steady_state_error_rad"),
}


def run_pair(
    contender: Contender,
    seed: int,
    out: Path,
    sine_duration_s: float,
    amplitude: float,
    domain_id: int | None = None,
    between_runs: Callable[[], None] = lambda: None,
) -> dict[str, float]:
    """One contender, one seed: the sine run, then the step run. The compared figures, keyed as in the table.
    ``between_runs`` is called after each run (a worker stops there when asked to)."""
    base = cfg.merge(cfg.load_stack(contender.preset, robot=contender.robot), {"pid_controller": contender.overrides})
    params = cfg.merge(base, {"sensor_node": {"seed": seed}})
    sine, _ = run_and_score(
        params, out / contender.name / f"sine_{seed}", duration_s=sine_duration_s, sim_time=True, domain_id=domain_id
    )
    between_runs()
    step_out = out / contender.name / f"step_{seed}"
    try:
        shape = {"amplitude": amplitude, "shaping": "min_time"}
        checked = check_step(base, **shape, sim_time=True, seed=seed, domain_id=domain_id)
        figures = step_response(checked, step_out, **shape)
    except ValueError as exc:  # no step in the recording
        raise RuntimeError(f"run in {step_out} failed: {exc}") from None
    between_runs()
    return _compared(sine, figures)


def _compared(sine: dict[str, float], step: dict[str, float]) -> dict[str, float]:
    """The compared figures of a sine run and a step run, keyed as in the table."""
    return {f"sine_{k}": sine[k] for k in COMPARED["sine"]} | {f"step_{k}": step[k] for k in COMPARED["step"]}


#: In process the step comes after 1.5 s at rest, not ``step.STEP_LEAD_S`` (0.5 s): the loop starts with
#: its first tick there, and the default's filter and observer settle within 1.5 s, not within 0.5 s.
IN_PROCESS_STEP_LEAD_S = 1.5


def run_pair_in_process(contender: Contender, seed: int, sine_duration_s: float, amplitude: float) -> dict[str, float]:
    """:func:`run_pair` on the in-process loop: the same parameters, the sim-time graph's computation, no ROS."""
    from robot_controller.experiments import inprocess

    base = cfg.merge(cfg.load_stack(contender.preset, robot=contender.robot), {"pid_controller": contender.overrides})
    sine = inprocess.simulate(base, duration_s=sine_duration_s, seed=seed).tracking_metrics()
    lead = {"trajectory_planner": {"step_time_s": IN_PROCESS_STEP_LEAD_S}}
    stepped = cfg.merge(step_params(base, amplitude, "min_time"), lead)
    result = inprocess.simulate(stepped, duration_s=IN_PROCESS_STEP_LEAD_S + STEP_AFTER_S, seed=seed)
    offset = cfg.per_joint("offset", stepped["trajectory_planner"]["offset"], result.reference.shape[1])
    return _compared(sine, loop_step_figures(result, amplitude, offset))


def loop_step_figures(result, amplitude: float, offset: np.ndarray) -> dict[str, float]:
    """Step figures (``step.step_figures``'s, the worst joint's) of an in-process run, on the TRUE angle at each
    tick, from the tick where the reference starts to move."""
    t, reference = result.tick_time_s, result.reference
    at_rest = np.flatnonzero(np.all(np.abs(reference - offset) <= 1e-9, axis=1))
    if at_rest.size == 0 or at_rest[-1] == len(t) - 1:
        raise RuntimeError("the in-process step run has no step")
    step_time = t[at_rest[-1]]
    per_joint = [
        metrics.step_metrics(
            t,
            result.true_position[:, j],
            initial=offset[j],
            target=offset[j] + amplitude,
            step_time_s=step_time,
            torque=result.command[t >= step_time, j],
        )
        for j in range(reference.shape[1])
    ]
    return {
        key: max((joint[key] for joint in per_joint), key=lambda v: abs(v) if np.isfinite(v) else np.inf)
        for key in per_joint[0]
    }
