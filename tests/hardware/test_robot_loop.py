"""The loop on the stand-in Franka robot through libfranka, the robot keeping the clock: the Panda tracks its
trajectory at 1 kHz from wherever it stood; a runaway torque is kept short of the robot's reflexes by our guard; a
reflex the robot does raise is named, and recovered from."""

import os

import numpy as np
import pytest

from robot_controller.hardware.franka_arm import ROTOR_INERTIA_KGM2, FrankaArm, RobotFault
from robot_controller.hardware.robot_loop import robot_loop
from robot_controller.parameters.files import load_stack
from tests.hardware.stand_in import skip_on_a_host_too_slow

pytestmark = pytest.mark.timeout(120)

DURATION_S = 10.0
#: mrad: what the worst joint's RMS must stay within after the start: the issue's bar (measured 0.15-1.6 on an idle
#: host, run to run)
TRACKING_RMS_MRAD = 2.0
WARMUP_S = 2.0


@pytest.fixture
def arm(stand_in):
    arm = FrankaArm(stand_in.host)
    if arm.errors():  # a reflex another test left set
        arm.recover()
    yield arm
    arm.close()


def test_the_panda_tracks_its_trajectory_on_the_robots_clock_from_where_it_stood(arm, stand_in):
    loop = robot_loop(load_stack(robot="panda"), ROTOR_INERTIA_KGM2)
    run = loop.run(arm, DURATION_S)
    said = f"{run.fault and run.fault.describe()}, {run.ended_by}; the stand-in's output ends: {stand_in.tail(6)}"
    if run.fault is not None:
        skip_on_a_host_too_slow(said, run.timing()["tick_compute_p99_ms"])
    assert run.fault is None and run.ended_by is None, said
    # libfranka made this thread SCHED_FIFO 99 where it could: put back, or every process started after inherits it
    assert os.sched_getscheduler(0) == os.SCHED_OTHER
    result = run.loop
    assert result.tick_time_s.size == round(DURATION_S * 1000)
    assert abs(np.median(np.diff(result.tick_time_s)) - 0.001) < 5e-5  # the robot's states came at its 1 kHz
    # Blended from where the robot stood: the first reference is its first position, nothing jumps.
    np.testing.assert_allclose(result.reference[0], result.true_position[0], atol=1e-9)
    speed = np.abs(np.diff(result.reference, axis=0)) / np.diff(result.tick_time_s)[:, None]
    assert (speed <= loop.guard.limits.velocity_rad_s).all(), speed.max(axis=0)  # within every speed limit
    error_mrad = (result.true_position - result.reference)[result.tick_time_s > WARMUP_S] * 1e3
    rms = np.sqrt((error_mrad**2).mean(axis=0))
    assert rms.max() < TRACKING_RMS_MRAD, rms
    # Every torque sent finite, within the range, its change within the FCI's rate (1 N·m a millisecond), with the
    # guard's margins (the robot's own checks, enforced here, never come into play): each within a step of what the
    # robot last took, which may be the one before the last sent.
    applied = result.applied
    assert np.isfinite(applied).all() and (np.abs(applied) <= loop.guard.max_torque_nm + 1e-5).all()
    gravity = np.array([loop.dynamics.gravity(q) for q in result.true_position])
    assert np.abs(np.diff(applied - gravity, axis=0)).max() <= 2 * loop.guard.max_step_nm + 1e-5  # (sent as float32)
    timing = run.timing()
    figures = ", ".join(f"{key} {value:.3g}" for key, value in timing.items())
    print(f"worst joint {rms.max():.2f} mrad RMS after {WARMUP_S:g} s; {figures}")
    assert 0.0 < timing["tick_compute_p50_ms"] < timing["tick_compute_max_ms"]
    assert run.success_rate.min() >= 0.0 and run.success_rate.max() <= 1.0


def test_a_runaway_torque_is_kept_short_of_the_robots_reflexes(arm):
    """A law gone wrong asks for the wrist's whole torque range for 3 s: the guard brakes the joint under its speed
    limit and stops it before its position limit; the robot, its motion limits enforced, never needs a reflex."""
    loop = robot_loop(load_stack(robot="panda"), ROTOR_INERTIA_KGM2)
    guard, limits = loop.guard, loop.guard.limits
    runaway = np.zeros(7)
    runaway[6] = limits.torque_nm[6]
    reading = arm.start()
    speeds, positions = [], []
    try:
        for _ in range(3000):
            gravity = loop.dynamics.gravity(reading.position)
            inertia = loop.dynamics.mass_matrix(reading.position).diagonal()
            arm.write(guard(gravity + runaway, gravity, reading.position, reading.velocity, inertia))
            reading = arm.read()
            speeds.append(np.abs(reading.velocity))
            positions.append(reading.position)
    except RobotFault as fault:
        pytest.fail(f"the robot raised a reflex: {fault.describe()}")
    finally:
        arm.finish()
    speeds, positions = np.array(speeds), np.array(positions)
    assert (speeds <= limits.velocity_rad_s).all(), speeds.max(axis=0)
    assert (positions < limits.upper_rad).all() and (positions > limits.lower_rad).all()
    assert guard.acted[6] > 0  # it was the guard that held it
    assert speeds[:, 6].max() > 0.5 * limits.velocity_rad_s[6]  # and the wrist did run away until it did


def test_a_reflex_is_named_and_the_robot_recovers(arm):
    """Without the guard the same runaway trips the robot's speed reflex: the fault names it, the robot keeps it set
    until recovered, and after recovery torque control starts again."""
    arm.start()
    torque = np.zeros(7)
    with pytest.raises(RobotFault) as raised:
        for _ in range(5000):
            # Half the robot's torque-rate limit a period, so a period this host misses (two steps in one) stays
            # within it too (at 1 N·m a period one missed period tripped controller_torque_discontinuity here):
            # the speed is what trips.
            torque[6] = min(torque[6] + 0.5, 12.0)
            arm.write(torque)
            arm.read()
    assert raised.value.reflexes == ["joint_velocity_violation"], raised.value.message
    assert arm.errors() == ["joint_velocity_violation"]
    arm.recover()
    assert arm.errors() == []
    reading = arm.start()
    assert np.isfinite(reading.position).all()
    arm.finish()
