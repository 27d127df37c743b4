"""The runs and timings ``robot-controller bench`` measures with: a recorded run of the graph
scored from its bag, the reference scenario at 1 kHz, a busy core beside the loop, the in-process
loop's ticks per second and the batch harness's simulated seconds per second."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.batch import run_batch
from robot_controller.core.laws.pid import PidConfig
from robot_controller.core.model import ArmDynamics, JointArmModel
from robot_controller.core.reference import make_trajectory
from robot_controller.experiments import inprocess
from robot_controller.runner import forking, launcher, plan
from robot_controller.runner.options import RunOptions
from robot_controller.runner.supervise import Watcher
from robot_controller.scoring import report, scored_run


def wall_run(
    params: cfg.Params,
    out: Path,
    duration_s: float,
    *,
    single_process: bool = False,
    sim_time: bool = False,
    paced: bool = False,
    watcher: Watcher | None = None,
) -> dict[str, Any]:
    options = RunOptions(duration_s, sim_time=sim_time, paced=paced, single_process=single_process)
    checked = plan.check(params, options)
    result = launcher.launch(checked, out, watcher=watcher)
    result.raise_if_interrupted()
    if result.exit_code != 0 and not scored_run.has_ticks(result):
        return {"failure": result.failure}
    scored = scored_run.score_launched(checked, result)
    # The host's figures beside the run's, a lockstep run's too (CPU, unrecorded messages): the bench measures them.
    values = scored.metrics | scored.timing | {"real_time_factor": result.real_time_factor}
    # The periods the host stretched are counted apart from the loop's own misses (none in lockstep): both reported.
    values.setdefault("missed_cycles_host", 0)
    if result.failure:
        values["failure"] = result.failure  # scored as far as it ran, and said so
    report.write_metrics(out / "metrics.json", values)
    return values


class HostFreezes:
    """A launcher watcher that freezes every node of the run together (``SIGSTOP``, then ``SIGCONT``
    ``freeze_s`` later) every ``every_s`` from ``first_s`` after the loop closed: a host that stalls, as a
    hypervisor taking the CPU does. The launcher waits through it too."""

    def __init__(self, freeze_s: float = 0.05, every_s: float = 5.0, first_s: float = 3.0) -> None:
        self.freeze_s, self.every_s, self.next_s = freeze_s, every_s, first_s
        self.count = 0

    def __call__(self, elapsed_s: float, pids: dict[str, int]) -> None:
        if elapsed_s < self.next_s:
            return
        self.next_s += self.every_s
        for pid in pids.values():
            os.kill(pid, signal.SIGSTOP)
        time.sleep(self.freeze_s)
        for pid in pids.values():
            os.kill(pid, signal.SIGCONT)
        self.count += 1


def kilohertz(params: cfg.Params) -> cfg.Params:
    """The reference scenario with the control loop, sensor and true state at 1 kHz."""
    return cfg.merge(
        params,
        {
            "pid_controller": {"control_rate_hz": 1000.0},
            "sensor_node": {"rate_hz": 1000.0},
            "simulator": {"publish_rate_hz": 1000.0, "control_rate_hz": 1000.0},  # the loop's one rate
            "trajectory_planner": {"publish_rate_hz": 1000.0},
        },
    )


def _ordinary_child() -> None:
    """Normal scheduling, and gone when the bench is (even if it is killed)."""
    os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
    forking.die_with_parent()


class BusyCore:
    """A process that keeps one core busy for as long as the context lasts."""

    def __enter__(self) -> BusyCore:
        # Ordinary scheduling, whatever this process runs at: it is the machine's
        # other work, not a real-time task.
        self.process = subprocess.Popen([sys.executable, "-c", "while True: pass"], preexec_fn=_ordinary_child)
        return self

    def __exit__(self, *exc_info) -> None:
        self.process.kill()
        self.process.wait()


def core_steps_per_s(duration_s: float, robot: str = "one_dof") -> float:
    """Control ticks per wall-clock second of the in-process loop on ``robot``'s
    parameters (:func:`inprocess.simulate`, seed 0), timing the loop alone:
    ``duration_s`` seconds of :func:`~robot_controller.blocks.wiring.run_loop` (planner,
    sensor, controller, actuator and the plant's physics steps, 10 per tick in the
    reference scenario). Not timed: the set-up (:func:`inprocess.prepare`: the URDF
    compiled, the trajectory planned, the gains designed) and a short warm-up run
    before it (imports, first calls)."""
    params = cfg.load_stack(robot=robot)
    inprocess.prepare(params, duration_s=min(duration_s, 0.5), seed=0)()  # the warm-up
    run = inprocess.prepare(params, duration_s=duration_s, seed=0)
    start = time.perf_counter()
    result = run()
    return len(result.tick_time_s) / (time.perf_counter() - start)


def batch_sim_s_per_s(batch: int, duration_s: float) -> tuple[float, float]:
    """Simulated seconds per wall second of ``batch`` gain sets at once; also the best RMS found."""
    rng = np.random.default_rng(0)
    pid = PidConfig(
        kp=rng.uniform(10, 100, (batch, 1)),
        ki=rng.uniform(0, 20, (batch, 1)),
        kd=rng.uniform(1, 8, (batch, 1)),
        output_limit=[10.0],
        integral_limit=[10.0],
        anti_windup="conditional_integration",
        back_calculation_time_s=0.1,
        derivative_source="velocity_error",
        derivative_filter_time_s=0.0,
        slew_rate_limit=0.0,
    )
    params = cfg.load_stack()
    start = time.perf_counter()
    rms = run_batch(
        model=JointArmModel.over_urdf(ArmDynamics(resources.default_urdf())),
        pid_config=pid,
        trajectory=make_trajectory("sine", joint_count=1),
        sensor=cfg.sensor_config(params["sensor_node"]),
        rng=rng,
        duration_s=duration_s,
        warmup_s=min(2.0, duration_s / 2),  # a short (--quick) run must still score something
    )
    return batch * duration_s / (time.perf_counter() - start), float(np.min(rms))
