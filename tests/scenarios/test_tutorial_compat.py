"""The tutorial's own planner and controller, unchanged, against our simulator,
motor and sensor. Their code is read from the tutorial text in shared/seed,
beside the repository (``../shared/seed``, where every checkout and CI have
it), at test time (not copied into this repository). Without it the test
skips, saying where it looked; under CI (``CI`` set) it fails instead."""

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from sensor_msgs.msg import JointState

from robot_controller import parameters as cfg
from robot_controller.runner import plan
from tests.rostools import RosProbe, wait_for

pytestmark = pytest.mark.ros

REPO = Path(__file__).resolve().parents[2]
SEED_DIRS = (REPO.parent / "shared" / "seed", REPO / "shared" / "seed")


def seed_node_source(filename: str) -> str:
    """The code block of the tutorial that follows the comment naming ``filename``."""
    for text_file in sorted(path for folder in SEED_DIRS for path in folder.glob("*.txt")):
        text = text_file.read_text()
        match = re.search(
            rf"^# robot_controller/robot_controller/{re.escape(filename)}\n(.*?^    main\(\)\n)",
            text,
            re.MULTILINE | re.DOTALL,
        )
        if match:
            return match.group(1)
    where = " or ".join(str(folder) for folder in SEED_DIRS)
    if os.environ.get("CI"):
        pytest.fail(f"the tutorial's {filename} is not in {where}: CI must have the tutorial beside the repository")
    pytest.skip(f"the tutorial's {filename} is not in {where} (the tutorial lives beside the repository)")


@pytest.mark.parametrize("world", ["wall_clock", "paced"])
def test_tutorial_planner_and_controller_drive_our_arm(tmp_path, ros_domain, world):
    """On the wall clock, and in the paced world of the default run (our nodes on the world's /clock)."""
    sources = {name: seed_node_source(f"{name}.py") for name in ("trajectory_planner", "pid_controller")}
    params = cfg.load_stack()
    if world == "paced":
        params = plan.world_waits_params(params)
        params["simulator"]["real_time_factor"] = 1.0
    params_file = cfg.write_params_file(params, tmp_path / "params.yaml")
    processes = []
    probe = RosProbe(ros_domain)
    try:
        for name in ("simulator", "motor_node", "sensor_node"):
            processes.append(
                subprocess.Popen(
                    [
                        sys.executable,
                        "-m",
                        f"robot_controller.nodes.{name}",
                        "--ros-args",
                        "--params-file",
                        str(params_file),
                    ],
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.STDOUT,
                )
            )
        for name, source in sources.items():
            script = tmp_path / f"seed_{name}.py"
            script.write_text(source)
            processes.append(
                subprocess.Popen(
                    [sys.executable, str(script)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
                )
            )
        true_states = probe.collect(JointState, "/sim/joint_states", qos=500)

        def moving():
            with probe.lock:
                return any(abs(m.position[0]) > 0.3 for _, m in true_states)

        wait_for(moving, 40, "the tutorial's controller to move our arm")
        # Judge the last 4 s, from 8 s on: the start is the tutorial's transient. Its planner's sine runs from its own
        # start, and its controller integrates error before the world starts; the first command then meets a
        # target up to 1 rad away and saturates (on a busy host it swung the arm over the top, 3.4 rad, and
        # back within 2.5 s).
        # The tutorial's loop lags a 1 rad, 0.5 Hz sine but follows it: a sine at 0.5 Hz fits its last 4 s. Beside
        # a CPU hog its start transient can outlast 8 s (residual 0.13 rad once): judged again every 4 s, to 20 s.
        fits = []
        for waited_s in (8.0, 4.0, 4.0, 4.0):
            time.sleep(waited_s)
            assert all(p.poll() is None for p in processes), "a node died"
            with probe.lock:
                # The tutorial's nodes run on the wall clock; the paced world's pauses with a busy host: judge the
                # arm on the tutorial's time base, when its states arrived.
                t = np.array([arrived for arrived, _ in true_states])
                q = np.array([m.position[0] for _, m in true_states])
            recent = t > t[-1] - 4.0
            basis = np.column_stack([np.sin(np.pi * t[recent]), np.cos(np.pi * t[recent]), np.ones(recent.sum())])
            coef, *_ = np.linalg.lstsq(basis, q[recent], rcond=None)
            fit = (np.hypot(coef[0], coef[1]), np.std(q[recent] - basis @ coef), np.abs(q[recent]).max())
            fits.append(fit)
            if 0.6 < fit[0] < 1.3 and fit[1] < 0.1 and fit[2] < 1.3:
                break
        amplitude, residual, reach = fits[-1]
        assert 0.6 < amplitude < 1.3, fits
        assert residual < 0.1, fits
        assert reach < 1.3, ("the arm swung past the reference's reach", fits)
    finally:
        probe.close()
        for p in processes:
            p.send_signal(signal.SIGINT)
        for p in processes:
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
    controller_log = processes[-1].stdout.read() if processes[-1].stdout else ""
    assert re.search(r"target=-?\d\.\d{3}, actual=-?\d\.\d{3}", controller_log), controller_log[-1000:]
