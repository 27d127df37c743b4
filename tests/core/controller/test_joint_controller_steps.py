"""The parts JointController.update() is made of, each on its own: the
health verdict, the tick clock, the state estimate's model prediction, the
planner's reference at a tick (no ROS, no sleeping)."""

import pytest

from robot_controller.core.controller import JointController
from robot_controller.core.controller.reference_in_force import MAX_AHEAD_S, PlannerReference
from robot_controller.core.controller.supervision import Readings, ReferenceSource, Status, TickClock, check_health
from robot_controller.core.controller.tick_state import StateAtTick
from tests.core.controller.joint_rig import PERIOD, arm, config, one

# --- health -----------------------------------------------------------------------------


def test_check_health_ranks_the_faults():
    cfg = config(sensor_timeout_s=0.5)
    readings = Readings()
    assert check_health(readings, 1.0, False, False, cfg).status is Status.NO_MEASUREMENT
    readings.accept(1.0, 1.0, one(0), one(0), cfg.max_reading_age_s)
    assert check_health(readings, 1.0, True, False, cfg).status is Status.STOPPED
    healthy = check_health(readings, 1.0 + 5 * PERIOD, False, False, cfg)
    assert healthy.status is Status.OK and not healthy.restart
    watchdog = check_health(readings, 1.0 + 6 * PERIOD, False, False, cfg)
    assert watchdog.status is Status.WATCHDOG and watchdog.restart
    lost = check_health(readings, 1.6, False, False, cfg)
    assert lost.status is Status.SENSOR_LOST and lost.restart
    braked = check_health(readings, 1.0, False, True, cfg)
    assert braked.status is Status.OK and braked.restart


def test_tick_clock_limits_the_period_and_notices_a_pause():
    clock = TickClock()
    assert clock.advance(1.0, PERIOD).dt_s == PERIOD
    tick = clock.advance(1.0 + PERIOD, PERIOD)
    assert tick.dt_s == PERIOD and not tick.paused
    tick = clock.advance(1.0 + 12 * PERIOD, PERIOD)
    assert tick.dt_s == 5 * PERIOD and tick.paused and tick.gap_s == 11 * PERIOD
    tick = clock.advance(1.0, PERIOD)  # not later than the last: the nominal period
    assert tick.dt_s == PERIOD and not tick.paused


# --- the estimate at the tick ------------------------------------------------------------


def test_the_model_is_integrated_under_each_command_from_its_tick_on():
    state = StateAtTick(1, arm(), None)
    state.remember_command(0.0, one(1.0))
    state.remember_command(0.01, one(-1.0))
    q, v = state.predict(one(0.2), one(0.5), 0.005, 0.015)
    q1, v1 = arm().predict(one(0.2), one(0.5), one(1.0), 0.005)
    q2, v2 = arm().predict(q1, v1, one(-1.0), 0.005)
    assert q[0] == pytest.approx(q2[0]) and v[0] == pytest.approx(v2[0])
    assert state.command_before(0.01)[0] == 1.0 and state.command_before(0.0)[0] == 0.0


def test_while_readings_are_missing_the_state_coasts_on_the_model_under_the_last_command():
    state = StateAtTick(1, arm(), None)
    readings = Readings()
    readings.accept(0.0, 0.0, one(0.2), one(0.5), 0.1)
    state.at_tick(0.0, readings, latency_compensation=False)
    state.remember_command(0.0, one(3.0))
    q, v = state.coast(0.05, readings)
    expected = arm().predict(one(0.2), one(0.5), one(3.0), 0.05)
    assert q[0] == pytest.approx(expected[0][0]) and v[0] == pytest.approx(expected[1][0])
    assert state.last_position(readings)[0] == q[0]


# --- the reference at the tick ----------------------------------------------------------


def test_reference_extrapolation_on_the_samples_velocity_and_acceleration():
    planner = PlannerReference()
    planner.receive(1.0, one(1.0), one(2.0), one(4.0), sample_time_s=1.0)
    point = planner.at(1.0625, extrapolate=True, control_period_s=PERIOD)
    assert point.position[0] == pytest.approx(1.0 + 2.0 * 0.0625 + 0.5 * 4.0 * 0.0625**2)
    assert point.velocity[0] == pytest.approx(2.25)
    assert point.source is ReferenceSource.EXTRAPOLATED and point.fresh
    held = planner.at(1.0625, extrapolate=False, control_period_s=PERIOD)
    assert held.position[0] == 1.0 and held.velocity[0] == 2.0 and held.source is ReferenceSource.TRAJECTORY
    late = planner.at(1.5, extrapolate=True, control_period_s=PERIOD)
    assert late.position[0] == pytest.approx(1.0 + 0.2 + 0.02) and not late.fresh  # at most 0.1 s ahead


def test_a_sample_sent_ahead_of_its_time_waits_for_it():
    # The lockstep planner sends the next tick's sample while this tick's is in force.
    planner = PlannerReference()
    planner.receive(0.0, one(0.0), one(0.0), one(0.0), sample_time_s=0.0)
    planner.receive(0.0, one(1.0), one(0.0), one(0.0), sample_time_s=PERIOD)
    assert planner.time_s == 0.0 and planner.sample[0][0] == 0.0
    assert planner.ready(0.0)  # and a tick at 0 does not wait for more
    assert planner.ready(PERIOD)  # the tick's own sample, taken when asked
    assert planner.time_s == PERIOD and planner.sample[0][0] == 1.0
    assert not planner.ready(2 * PERIOD)  # the next one is due and not in
    # Stamped further ahead than MAX_AHEAD_S: a clock that is wrong, taken as it comes.
    planner.receive(PERIOD, one(2.0), one(0.0), one(0.0), sample_time_s=PERIOD + MAX_AHEAD_S + 1.0)
    assert planner.sample[0][0] == 2.0


def test_the_controller_uses_each_sample_at_its_own_tick():
    c = JointController(config(), 1)
    c.set_measurement(0.0, 0.0, one(0.0), one(0.0))
    c.set_reference(0.0, one(0.0), one(0.0), one(0.0), sample_time_s=0.0)
    c.set_reference(0.0, one(0.1), one(0.0), one(0.0), sample_time_s=PERIOD)
    assert c.update(0.0).reference[0] == 0.0
    c.set_measurement(PERIOD, PERIOD, one(0.0), one(0.0))
    assert c.update(PERIOD).reference[0] == 0.1
