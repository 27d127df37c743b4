"""Each world of a campaign identified, and tuned, before its run as its user would (spec ``identify: true``,
``tune: TARGET``): ``identify``'s chirp run in process on the world as drawn (its friction, its lag, its payload),
the same fits as ``identify`` (:mod:`~robot_controller.experiments.identify_chain`, the drive's lag), then, with
``tune``, each joint's design for the target verified against the gains in force over seeds as ``tune --quick``
verifies it (in process: the graph's blocks, the graph's figures to 1e-6), kept only if it is better past its spread.

What it answers: does the stack track every arm of a kind once each is identified (a campaign over friction, lag and
payload the model is not told of asks something else: how far a model may be off)."""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.blocks.wiring import LoopResult
from robot_controller.experiments import identify as identification
from robot_controller.experiments import inprocess
from robot_controller.experiments.autotune import chain
from robot_controller.experiments.autotune.procedure import CHAIN_CHECK_S, VERIFY_SEEDS
from robot_controller.experiments.autotune.verification import Verification
from robot_controller.experiments.campaign.run_figures import figures

#: s of sim time of the chirp each world is identified from (``identify``'s own)
EXCITATION_S = 20.0

# (params, duration s, seed) → (the worst joint's tracking RMS rad, whether the run ended without a stop)
Scorer = Callable[[cfg.Params, float, int], tuple[float, bool]]


def _quiet(_: str) -> None:
    """Progress lines nobody reads (a campaign's runs say their figures in its report)."""


def loop_recording(result: LoopResult, params: cfg.Params) -> SimpleNamespace:
    """The in-process loop's record as ``identify`` reads a bag's: each true sample with the torque that acted up to
    it (the drive's, applied over the period before), a disturbance's span left out."""
    applied = np.vstack([np.zeros((1, result.applied.shape[1])), result.applied[:-1]])
    sim, n = params["simulator"], result.applied.shape[1]
    torque = cfg.per_joint("disturbance_torque_nm", sim["disturbance_torque_nm"], n)
    start_s, end_s = sim["disturbance_start_s"], sim["disturbance_start_s"] + sim["disturbance_duration_s"]
    pushed = np.any(torque != 0) and sim["disturbance_duration_s"] > 0
    disturbance = (np.array([start_s, end_s]), np.vstack([torque, np.zeros(n)])) if pushed else (np.zeros(0), None)
    return SimpleNamespace(
        true_time_s=result.tick_time_s,
        true_position=result.true_position,
        true_velocity=result.true_velocity,
        true_effort=applied,
        joint_count=n,
        brakes_time_s=np.zeros(0),
        brakes=np.zeros((0, n)),
        disturbance_time_s=disturbance[0],
        disturbance=disturbance[1] if pushed else np.zeros((0, n)),
    )


def identified(params: cfg.Params, seed: int) -> tuple[cfg.Params, dict[str, Any]]:
    """``params`` with the controller's model as ``identify`` finds it on this world (seed ``seed``'s noise; once more
    from the model found where the chirp was followed worse than ``REFINE_ABOVE_RAD``, as ``identify`` does), and
    what it found of the drive (``identified_drive_lag_s``) and how many chirps it took (``identify_runs``)."""
    found, (facts, followed_rad) = _identified_once(params, seed)
    if followed_rad <= identification.REFINE_ABOVE_RAD:
        return found, {**facts, "identify_runs": 1}
    found, (facts, _) = _identified_once(cfg.merge(params, {"pid_controller": found["pid_controller"]}), seed)
    return found, {**facts, "identify_runs": 2}


def _identified_once(params: cfg.Params, seed: int) -> tuple[cfg.Params, tuple[dict[str, Any], float]]:
    """``params`` with the controller's model as ``identify`` finds it on this world (seed ``seed``'s noise), and
    what it found of the drive (``identified_drive_lag_s``)."""
    run_params = identification.excitation_params(params, EXCITATION_S)
    run_params = cfg.merge(run_params, {"sensor_node": {"seed": seed}})
    result = inprocess.simulate(run_params, duration_s=EXCITATION_S, seed=seed)
    metrics = result.tracking_metrics()
    facts: dict[str, Any] = {"duration_s": EXCITATION_S, "seed": seed, "start_hz": identification.START_HZ}
    facts |= {"end_hz": identification.END_HZ, "tracking_rms_rad": metrics["tracking_rms_rad"]}
    facts |= {"peak_torque_nm": float(np.abs(result.command).max()), "saturated_ticks": 0}
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder)
        recording = loop_recording(result, run_params)
        found = identification.fit_run(run_params, out, recording, facts, (result.command, result.applied), _quiet)
        overlay = cfg.read_params_file(out / "identified.yaml")
    drive = {"identified_drive_lag_s": float(found["drive_lag_s"])}
    return cfg.merge(params, overlay), (drive, float(metrics["tracking_rms_rad"]))


def tuned(params: cfg.Params, target: str, seed: int, score: Scorer) -> tuple[cfg.Params, dict[str, Any]]:
    """``params`` with each joint's gains designed for ``target`` where the design beats those in force past its
    spread over ``tune --quick``'s seeds from ``seed`` (``score``: one run's figures), else as they are."""
    designs = chain.design_joints(params, target)
    if chain.in_force(params, designs):
        return params, {"tuned": 0}
    after = cfg.merge(params, {"pid_controller": chain.overlay(designs)})
    seeds, duration_s = tuple(range(seed, seed + VERIFY_SEEDS[True])), CHAIN_CHECK_S[True]
    before_runs = [score(params, duration_s, s) for s in seeds]
    after_runs = [score(after, duration_s, s) for s in seeds]
    checked = Verification(
        seeds,
        tuple(rms for rms, _ in before_runs),
        tuple(rms for rms, _ in after_runs),
        all(ok for _, ok in after_runs),
        duration_s,
    )
    return (after, {"tuned": 1}) if checked.recommended else (params, {"tuned": 0})


def prepared(params: cfg.Params, seed: int, tune: str, row: dict[str, Any]) -> cfg.Params:
    """The world identified (and with ``tune``, tuned for it) as its user would before its run of seed ``seed``; what
    that found goes into ``row`` (``identified_drive_lag_s``, ``identify_runs``, ``tuned``, ``prepare_s``)."""
    start = time.perf_counter()
    params, found = identified(params, seed)
    if tune:
        params, tuned_here = tuned(params, tune, seed, _score)
        found |= tuned_here
    row.update(found, prepare_s=time.perf_counter() - start)
    return params


def _score(params: cfg.Params, duration_s: float, seed: int) -> tuple[float, bool]:
    """One run's worst-joint tracking RMS (rad) and whether it ended without a stop."""
    out = figures(cfg.merge(params, {"sensor_node": {"seed": seed}}), duration_s, seed)
    return out["tracking_rms_rad"], out["faults"] == 0
