"""The latency guard (no ROS): when the loop's delay is past what the gains
survive, the controller stops the motion on its model and lets the brakes hold
it, instead of oscillating; it re-acquires once the delay is back within margin."""

from collections import deque

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller import resources
from robot_controller.core.controller import JointController, Status
from robot_controller.core.controller.supervision import CLEAR_AFTER_S, COMMAND_MEMORY_S, WINDOW, LatencyGuard
from robot_controller.core.model import ArmDynamics, MujocoPlant
from robot_controller.core.reference import make_trajectory

PERIOD = 0.01


def test_the_loop_is_late_past_the_margin_and_on_time_after_a_second_within_half_of_it():
    guard = LatencyGuard(tolerated_s=0.02, compensated_s=0.0)
    for _ in range(WINDOW):
        guard.reading(0.001)
    assert not guard.update(0.0).late
    for _ in range(WINDOW):
        guard.reading(0.03)
    state = guard.update(1.0)
    assert state.late and state.delay_s == pytest.approx(0.03) and state.tolerated_s == 0.02
    for _ in range(WINDOW):
        guard.reading(0.015)  # within the margin, not within half of it: still late
    assert guard.update(2.0).late and guard.update(5.0).late
    for _ in range(WINDOW):
        guard.reading(0.005)
    assert guard.update(6.0).late
    assert guard.update(6.0 + CLEAR_AFTER_S / 2).late
    assert not guard.update(6.0 + CLEAR_AFTER_S).late


def test_one_late_reading_among_timely_ones_is_not_latency():
    guard = LatencyGuard(tolerated_s=0.02, compensated_s=0.0)
    for k in range(3 * WINDOW):
        guard.reading(0.09 if k % WINDOW == 0 else 0.001)
        assert not guard.update(k * PERIOD).late


def test_compensated_reading_age_does_not_count_command_delay_does_until_forgotten():
    guard = LatencyGuard(tolerated_s=0.02, compensated_s=0.1)
    for _ in range(WINDOW):
        guard.reading(0.08)  # stamped: the model brings it to the tick
    assert guard.delay_s(0.0) == 0.0 and not guard.update(0.0).late
    for _ in range(WINDOW):
        guard.command(receipt_s=1.0, delay_s=0.04)  # commands are never compensated
    assert guard.update(1.0).late
    assert guard.delay_s(1.0 + COMMAND_MEMORY_S + 0.01) == 0.0  # receipts stop: forgotten


def test_a_controller_without_its_guard_never_reports_late():
    params = cfg.load_stack()["pid_controller"]
    c = JointController(cfg.controller_config(params, 1), 1, ArmDynamics(resources.default_urdf()))
    c.command_delay(0.0, 1.0)
    assert c.latency is None


def run_loop(command_delay_periods: int, late_from: int, late_until: int, ticks: int):
    """The default controller on the MuJoCo arm, a sine; its commands reach the arm
    ``command_delay_periods`` late on ticks [late_from, late_until), each one's delay reported
    as the motor's receipts report it. A torque-free tick with the brake's work: the arm held."""
    params = cfg.load_stack()["pid_controller"]
    c = JointController(cfg.controller_config(params, 1), 1, ArmDynamics(resources.default_urdf()), latency_guard=True)
    plant = MujocoPlant(resources.default_urdf(), 0.001)
    plant.reset(np.zeros(1))
    trajectory = make_trajectory("sine", joint_count=1)
    pending: deque = deque()
    current = np.zeros(1)
    log = []
    for k in range(ticks):
        t = k * PERIOD
        c.set_reference(t, *trajectory.sample(t), sample_time_s=t)
        q, v = plant.state()
        c.set_measurement(t, t, q, v)
        out = c.update(t)
        delay = command_delay_periods if late_from <= k < late_until else 0
        if out.status.commanding:
            pending.append((k + delay, t, out.command))
        else:
            pending.clear()
            current = None  # the drive's timeout: torque off, the brake holds the arm
        while pending and pending[0][0] <= k:
            _, issued_s, current = pending.popleft()
            c.command_delay(t, t - issued_s)
        if current is None:
            plant.reset(q)  # braked where it is
        else:
            plant.step(current, 10)
        log.append((t, out.status, out.reference[0], q[0]))
    return c, log


def test_commands_later_than_the_margin_stop_the_arm_then_it_reacquires():
    c, log = run_loop(4, 100, 300, 800)  # 40 ms: twice the default gains' 20 ms margin
    assert c.delay_margin_periods() == 2
    statuses = [status for _, status, _, _ in log]
    first_late = statuses.index(Status.LATE)
    assert 100 < first_late < 120  # within a few receipts
    assert Status.LATE_STOPPED in statuses[first_late:300]
    # While late: no oscillation: the arm stays near where the stop brought the reference.
    late = [(r, q) for _, s, r, q in log[first_late:300] if s in (Status.LATE, Status.LATE_STOPPED)]
    assert max(abs(r - q) for r, q in late) < 0.1
    # On time again (after the commands' delays are forgotten and a second within half the margin):
    # the arm is led back onto the sine and tracks it.
    back = statuses.index(Status.REACQUIRING, 300)
    assert back < 300 + int((COMMAND_MEMORY_S + CLEAR_AFTER_S + 0.5) / PERIOD)
    tail = [abs(r - q) for _, s, r, q in log[-100:]]
    assert statuses[-1] is Status.OK and max(tail) < 0.01


def test_within_the_margin_nothing_changes():
    c, log = run_loop(1, 100, 300, 400)  # 10 ms: within the 20 ms margin
    assert all(status is not Status.LATE for _, status, _, _ in log)
    assert c.latency is not None and not c.latency.late


def timely_controller() -> JointController:
    params = cfg.load_stack()["pid_controller"]
    return JointController(
        cfg.controller_config(params, 1), 1, ArmDynamics(resources.default_urdf()), latency_guard=True
    )


def test_readings_refused_as_too_old_make_the_loop_late():
    # Each reading 0.15 s old: every one is refused (max_reading_age_s 0.1), and it is those
    # that show the loop late; kept ones are at most as old as the latency compensation covers.
    c = timely_controller()
    c.set_reference(0.0, np.zeros(1), np.zeros(1), np.zeros(1), sample_time_s=0.0)
    c.set_measurement(0.0, 0.0, np.zeros(1), np.zeros(1))
    assert c.update(0.0).status.commanding
    for k in range(1, 30):
        t = k * PERIOD
        c.set_reference(t, np.zeros(1), np.zeros(1), np.zeros(1), sample_time_s=t)
        assert c.set_measurement(t - 0.15, t, np.zeros(1), np.zeros(1)) is not None  # refused
        out = c.update(t)
    assert c.latency.late and c.latency.delay_s == pytest.approx(0.05)
    assert out.status in (Status.LATE, Status.LATE_STOPPED)


def test_readings_missing_while_the_brakes_hold_command_nothing():
    # A stop on the model would command torques, and the first one releases the brakes.
    c = timely_controller()
    c.set_reference(0.0, np.zeros(1), np.zeros(1), np.zeros(1), sample_time_s=0.0)
    c.set_measurement(0.0, 0.0, np.zeros(1), np.zeros(1))
    c.brakes(True)
    assert c.update(0.0).status.commanding  # readings fresh: the loop starts, and its torques release them
    statuses = [c.update(k * PERIOD).status for k in range(1, 20)]  # no reading after the first
    assert Status.WATCHDOG not in statuses
    assert statuses[-1] is Status.SENSOR_LOST and not statuses[-1].commanding
    c.brakes(False)
    c2 = timely_controller()  # the same silence with the brakes off: the controlled stop on the model
    c2.set_reference(0.0, np.zeros(1), np.zeros(1), np.zeros(1), sample_time_s=0.0)
    c2.set_measurement(0.0, 0.0, np.zeros(1), np.zeros(1))
    c2.update(0.0)
    assert Status.WATCHDOG in [c2.update(k * PERIOD).status for k in range(1, 20)]


def test_gains_leaving_a_joint_less_than_a_period_of_delay_margin_are_refused_naming_it():
    from robot_controller.core.controller import check_delay_margin
    from robot_controller.core.errors import ConfigError
    from robot_controller.parameters.builders import arm_model

    ctrl = dict(cfg.load_stack(robot="planar2")["pid_controller"], controller_type="pid")
    dynamics = arm_model(ctrl)
    check_delay_margin(cfg.controller_config(ctrl, 2), dynamics, 2)  # one value each, scaled: kept
    stiff = dict(ctrl, kp=[50.0, 2000.0])
    with pytest.raises(ConfigError, match=r"controller_type pid: .* joint elbow a delay margin of 0 control periods"):
        check_delay_margin(cfg.controller_config(stiff, 2), dynamics, 2)
    check_delay_margin(cfg.controller_config(dict(stiff, min_delay_margin_periods=0), 2), dynamics, 2)  # no check
