"""libfranka's client (pylibfranka) drives the stand-in Franka robot (franka-sim, our Panda inside) in torque control:
2,000 cycles of zero torque leave the arm where it was, every reading finite and within the Panda's limits, and the
server stops cleanly. franka-sim lives in a venv of its own, made by ``make franka-sim`` (run here when missing).

The server takes libfranka's fixed port 1337 for the test's ~3 s: the module's lock queues a second stand-in on this
host (another worker, another checkout) instead of letting them clash."""

import socket
import time

import numpy as np
import pytest

from robot_controller.core.model.joint_limits import joint_limits
from robot_controller.hardware import franka_server
from robot_controller.hardware.franka_arm import scheduling_kept
from robot_controller.robots.description import describe
from robot_controller.runner.processes import sample
from tests.hardware.stand_in import stand_in_venv

CYCLES = 2000
STILL_RAD = 0.05  # gravity compensated and nothing commanded: the arm holds far closer than this


def _port_open(host: str, port: int) -> bool:
    with socket.socket() as probe:
        probe.settimeout(1.0)
        return probe.connect_ex((host, port)) == 0


def test_pylibfranka_holds_the_stand_in_panda_under_zero_torque(tmp_path):
    pylibfranka = pytest.importorskip("pylibfranka", reason="the franka extra: pip install -e '.[dev]'")
    venv = stand_in_venv()
    limits = joint_limits(describe("panda").path)
    mjcf = franka_server.write_panda_mjcf(tmp_path)
    zero = pylibfranka.Torques([0.0] * 7)
    q, rates, stamps = np.empty((CYCLES, 7)), np.empty(CYCLES), np.empty(CYCLES)
    with franka_server.FrankaServer(mjcf, venv=venv) as server:
        with scheduling_kept():  # (libfranka would leave this thread SCHED_FIFO 99, and every process after it)
            robot = pylibfranka.Robot(server.host, pylibfranka.RealtimeConfig.kIgnore)
            control = robot.start_torque_control()
        before = sample(server.pid)
        try:
            for k in range(CYCLES):
                state, _ = control.readOnce()
                stamps[k] = time.perf_counter()
                q[k], rates[k] = state.q, state.control_command_success_rate
                control.writeOnce(zero)
        except pylibfranka.ControlException as exc:
            pytest.fail(f"cycle {k}: {exc}; the server's output ends: {server.tail(8)}")
        after = sample(server.pid)
        errors, mode = state.current_errors, state.robot_mode
        robot.stop()
        del control, robot  # the client leaves before the server stops
    period_ms = np.diff(stamps) * 1e3
    cpu_pct = 100 * (after.cpu_s - before.cpu_s) / (stamps[-1] - stamps[0])
    print(
        f"franka-sim: up in {server.startup_s:.2f} s; period median {np.median(period_ms):.3f} ms, "
        f"p99 {np.percentile(period_ms, 99):.3f} ms, max {period_ms.max():.3f} ms; server {cpu_pct:.0f} % of a core"
    )
    assert np.isfinite(q).all()
    assert ((q >= limits.lower) & (q <= limits.upper)).all(), (q.min(axis=0), q.max(axis=0))
    moved = np.abs(q - q[0]).max(axis=0)
    assert (moved < STILL_RAD).all(), moved
    # The share of our commands the server received over its last cycles: reported, and some arrived.
    assert ((rates >= 0) & (rates <= 1)).all() and rates[100:].min() > 0, rates
    assert not errors and mode == pylibfranka.RobotMode.Move, (errors, mode)
    assert server.exit_code == 0, server.tail(8)
    assert not _port_open(server.host, server.port)
