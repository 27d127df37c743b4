"""The campaign's speed for ``bench``: runs per second on 1 and 2 local workers (the scaling); the time a worker slot
spends on no run, per run, locally and on a Ray head started here (Ray's overhead); and the in-process loop's time
against its floor, the MuJoCo calls it must make (the plant's steps and the controller's model: its filter and
feedforward), timed in the same run."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import mujoco
import yaml

from robot_controller.core.controller.controller import JointController
from robot_controller.core.model.mujoco_plant import MujocoPlant
from robot_controller.experiments import inprocess
from robot_controller.experiments.campaign import executors
from robot_controller.experiments.campaign.campaign import contenders, tasks
from robot_controller.experiments.campaign.spec import load_spec

#: What every run of the bench's campaign varies: the one-joint worlds of the sensor and the drive.
VARY = {
    "sensor_node.delay_s": {"uniform": [0.0, 0.03]},
    "sensor_node.position_noise_std": {"loguniform": [0.001, 0.02]},
    "motor_node.lag_time_constant_s": {"uniform": [0.0, 0.02]},
}
#: The MuJoCo functions the loop's core calls (the plant and the controller's arm model).
MUJOCO_CALLS = ("mj_step", "mj_forward", "mj_inverse", "mj_kinematics", "mj_comPos", "mj_crb", "mj_fullM", "mj_jac")


def campaign_figures(out: Path, runs: int, duration_s: float) -> dict[str, Any]:
    """``runs`` one-joint runs of ``duration_s`` on 1 and 2 local workers and on a 2-CPU Ray head started here."""
    out.mkdir(parents=True, exist_ok=True)
    spec_path = out / "campaign.yaml"
    body = {"robot": "one_dof", "duration_s": duration_s, "runs": runs, "seed": 1, "vary": VARY}
    spec_path.write_text(yaml.safe_dump(body, sort_keys=False))
    spec = load_spec(spec_path)
    todo = tasks(spec, contenders(spec, None), set())
    figures: dict[str, Any] = {"campaign_runs": runs, "campaign_run_s": duration_s}
    walls = {}
    for workers in (1, 2):
        start = time.perf_counter()
        rows = list(executors.run_local(todo, workers))
        walls[workers] = time.perf_counter() - start
        figures[f"campaign_runs_per_s_{workers}w"] = runs / walls[workers]
        # The share of a core each run had: below 1, the host gave the workers less than a core each.
        figures[f"campaign_core_share_{workers}w"] = sum(r["cpu_s"] for r in rows) / sum(r["wall_s"] for r in rows)
        figures[f"campaign_idle_ms_per_run_{workers}w"] = _idle_ms_per_run(rows, walls[workers], workers)
    figures["campaign_runs_per_s_per_worker"] = figures["campaign_runs_per_s_1w"]
    figures["campaign_scaling_2w"] = walls[1] / walls[2]
    figures.update(_ray_figures(todo))
    return figures


def _idle_ms_per_run(rows: list[dict], wall_s: float, slots: int) -> float:
    """The time a worker slot spent on no run, per run (sending tasks, fetching rows, starting workers): the campaign's
    wall time on every slot less the runs' own, measured in the same campaign, so a busy host inflates both alike."""
    return 1e3 * (wall_s * slots - sum(r["wall_s"] for r in rows)) / len(rows)


def _ray_figures(todo: list) -> dict[str, Any]:
    import ray

    with ray_head(cpus=2) as address:
        start = time.perf_counter()
        cpus = executors.connect_ray(address)
        connect_s = time.perf_counter() - start
        try:
            start = time.perf_counter()
            rows = list(executors.ray_rows(todo, cpus))
            wall_s = time.perf_counter() - start
        finally:
            ray.shutdown()
    return {
        "campaign_ray_connect_s": connect_s,
        "campaign_ray_overhead_ms_per_run": _idle_ms_per_run(rows, wall_s, cpus),
    }


@contextmanager
def ray_head(cpus: int) -> Iterator[str]:
    """A Ray head on this host with ``cpus`` CPUs on a free port, in a session of its own; ended by its group."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    temp = Path(tempfile.gettempdir()) / f"ray-bench-{os.getpid()}"  # Ray's socket paths must stay short
    command = [str(Path(sys.executable).with_name("ray")), "start", "--head", f"--port={port}", f"--num-cpus={cpus}"]
    command += ["--include-dashboard=false", "--disable-usage-stats", f"--temp-dir={temp}", "--block"]
    head = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and head.poll() is None:
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", port)) == 0:
                    break
            time.sleep(0.2)
        yield f"127.0.0.1:{port}"
    finally:
        for sig, wait_s in ((signal.SIGTERM, 10), (signal.SIGKILL, 10)):
            try:
                os.killpg(head.pid, sig)
                head.wait(timeout=wait_s)
                break
            except ProcessLookupError:
                break
            except subprocess.TimeoutExpired:
                continue


def loop_floor(params: dict, duration_s: float) -> dict[str, float]:
    """The in-process loop's wall time over ``duration_s`` sim s, and, timed in a second run (each call wrapped by a
    timer, whose own cost lands in the loop's time): its MuJoCo calls alone (the world's and the controller's model's),
    the world's physics steps alone (the steps the loop must make), and the controller's ticks' share of the loop."""
    inprocess.prepare(params, duration_s=min(duration_s, 0.5), seed=0)()  # warm-up: imports, first calls
    bare = inprocess.prepare(params, duration_s=duration_s, seed=0)
    start = time.perf_counter()
    bare()
    bare_s = time.perf_counter() - start
    spent = {"s": 0.0, "calls": 0}
    originals = {name: getattr(mujoco, name) for name in MUJOCO_CALLS}

    def timed(call):
        def wrapper(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return call(*args, **kwargs)
            finally:
                spent["s"] += time.perf_counter() - t0
                spent["calls"] += 1

        return wrapper

    parts = {"physics": 0.0, "controller": 0.0}
    methods = {"physics": (MujocoPlant, "step"), "controller": (JointController, "update")}
    unwrapped = {part: getattr(owner, name) for part, (owner, name) in methods.items()}

    def timed_part(part, method):
        def wrapper(*args, **kwargs):
            t0 = time.perf_counter()
            try:
                return method(*args, **kwargs)
            finally:
                parts[part] += time.perf_counter() - t0

        return wrapper

    run = inprocess.prepare(params, duration_s=duration_s, seed=0)
    for name, call in originals.items():
        setattr(mujoco, name, timed(call))
    for part, (owner, name) in methods.items():
        setattr(owner, name, timed_part(part, unwrapped[part]))
    try:
        start = time.perf_counter()
        run()
        timed_s = time.perf_counter() - start
    finally:
        for name, call in originals.items():
            setattr(mujoco, name, call)
        for part, (owner, name) in methods.items():
            setattr(owner, name, unwrapped[part])
    physics_s = parts["physics"]
    return {
        "loop_s": bare_s,
        "loop_timed_s": timed_s,
        "mujoco_s": spent["s"],
        "mujoco_calls": spent["calls"],
        "loop_vs_floor": bare_s / spent["s"] if spent["s"] else float("nan"),
        "physics_s": physics_s,
        "loop_vs_physics": bare_s / physics_s if physics_s else float("nan"),
        "controller_share": parts["controller"] / timed_s if timed_s else float("nan"),
    }
