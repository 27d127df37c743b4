"""JointController through update() and its named steps, driven directly (no
ROS, no sleeping: times are numbers): health (watchdog, sensor timeout, stale
readings, e-stop, brakes, pauses), the estimate at the tick, the reference at
the tick (extrapolated, held, stopped, blended back), the law and law_in_force."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robot_controller.core.controller import ControlOutput, JointController, Status
from robot_controller.core.controller.supervision import ReferenceSource
from robot_controller.core.laws import Reference
from robot_controller.core.laws.pid import PidTerms
from tests.core import configs
from tests.core.controller.joint_rig import PERIOD, TORQUE_MAX, arm, config, one, run, tracking

# --- health: watchdog, sensor timeout, stale readings, e-stop, brakes, pauses -------------


def test_watchdog_starts_a_controlled_stop_after_watchdog_periods_without_readings():
    c = tracking(speed=1.0)  # last reading at tick 16
    outs = run(c, range(17, 30), speed=1.0, readings=False)
    statuses = [out.status for out in outs]
    assert statuses == [Status.OK] * 5 + [Status.WATCHDOG] * 8  # silent > 5 periods from tick 22
    assert all(out.reference_source is ReferenceSource.TRAJECTORY for out in outs[:5])
    stop = outs[5:]
    assert all(out.reference_source is ReferenceSource.SENSOR_STOP and out.status.commanding for out in stop)
    # From where the trajectory is at tick 22 (no jump), to rest after v²/(2·20 rad/s²) = 0.025 rad.
    assert stop[0].reference[0] == pytest.approx(22 * PERIOD)
    assert stop[-1].reference[0] == pytest.approx(22 * PERIOD + 0.025)
    assert stop[-1].reference[0] == stop[-2].reference[0]
    assert all(np.all(np.abs(out.command) <= TORQUE_MAX) for out in stop)


def test_readings_missing_past_the_sensor_timeout_turn_the_torque_off():
    c = tracking(speed=1.0, sensor_timeout_s=0.25)
    outs = run(c, range(17, 36), speed=1.0, readings=False)
    assert [out.status for out in outs[5:16]] == [Status.WATCHDOG] * 11
    for out in outs[16:]:  # silent > 0.25 s from tick 33
        assert out.status is Status.SENSOR_LOST and not out.status.commanding
        assert out.reference_source is ReferenceSource.NONE
        assert np.all(out.command == 0.0)
        assert out.reference[0] == out.measured[0] == pytest.approx(16 * PERIOD)  # the last estimate


def test_a_stale_reading_is_refused_and_is_no_sign_of_life():
    c = JointController(config(max_reading_age_s=0.1), 1)
    why = c.set_measurement(0.0, 0.25, one(0.3), one(0.0))
    assert why is not None and "old" in why and not c.has_measurement
    why = c.set_measurement(0.5, 0.25, one(0.3), one(0.0))
    assert why is not None and "in the future" in why and not c.has_measurement
    assert c.update(0.25).status is Status.NO_MEASUREMENT
    assert c.set_measurement(0.2, 0.25, one(0.3), one(0.0)) is None
    assert c.has_measurement and c.measurement_stamp_s == 0.2

    c = tracking()
    for k in range(17, 24):  # readings keep coming, but 0.2 s old: refused
        t = k * PERIOD
        c.set_reference(t, one(0), one(0), one(0), sample_time_s=t)
        assert c.set_measurement(t - 0.2, t, one(0), one(0)) is not None
        out = c.update(t)
    assert out.status is Status.WATCHDOG


def test_no_reading_yet_commands_nothing():
    c = JointController(config(), 1)
    c.set_reference(0.0, one(1.0), one(0), one(0))
    out = c.update(0.0)
    assert out.status is Status.NO_MEASUREMENT and out.reference_source is ReferenceSource.NONE
    assert np.all(out.command == 0.0) and not out.status.commanding


def test_e_stop_commands_nothing_and_its_release_leads_the_arm_back_from_where_it_is():
    c = tracking()
    c.halt(True)
    out = run(c, [17], arm_at=0.4)[0]
    assert out.status is Status.STOPPED and np.all(out.command == 0.0)
    assert out.reference_source is ReferenceSource.NONE and out.reference[0] == 0.4
    c.halt(False)
    out = run(c, [18], arm_at=0.4)[0]
    assert out.status is Status.REACQUIRING and out.reference_source is ReferenceSource.REACQUIRE_BLEND
    assert out.reference[0] == pytest.approx(0.4)  # the blend starts at the arm, not at the trajectory (0)


def test_while_the_brakes_hold_the_reference_restarts_from_the_arm_every_tick():
    c = tracking()
    pushed = run(c, range(17, 30), arm_at=0.3)[-1]  # the arm held off the trajectory: the integral builds
    assert pushed.status is Status.OK and pushed.terms.i[0] < -0.01
    c.brakes(True)
    for out in run(c, range(30, 40), arm_at=0.3):
        assert out.status is Status.REACQUIRING and out.reference_source is ReferenceSource.REACQUIRE_BLEND
        assert out.reference[0] == pytest.approx(0.3)  # the blend starts at the arm
        assert out.terms.i[0] == 0.0  # the integral restarted (and no error to build it)
    c.brakes(False)
    outs = run(c, range(40, 70), arm_at=None)
    assert outs[-1].status is Status.OK


def test_a_reading_from_before_the_brakes_is_where_they_hold_the_arm_not_advanced_on_its_speed():
    """The controller frozen mid-swing: the world brakes the arm and goes on; on its return the newest reading
    is from before the brakes. Advanced on its speed it put the arm where it never went (0.1 rad off beside a
    CPU hog: a reading 40 ms old at 3 rad/s)."""
    c = tracking(speed=3.0, latency_compensation=True)  # the last reading at tick 16, at 3 rad/s
    c.brakes(True)
    t = 20 * PERIOD  # four periods on (inside the watchdog's five), no reading since
    c.set_reference(t, one(3.0 * t), one(3.0), one(0.0), sample_time_s=t)
    out = c.update(t)
    assert out.status is Status.REACQUIRING and out.reference_source is ReferenceSource.REACQUIRE_BLEND
    assert out.measured[0] == pytest.approx(16 * PERIOD * 3.0)  # where the reading put it, at rest
    assert out.reference[0] == pytest.approx(out.measured[0])  # the blend starts at the arm
    c.brakes(False)
    # Released, the readings advance on their speed again.
    c.set_measurement(t - 0.005, t, one(0.5), one(1.0))
    assert c.update(t + PERIOD).measured[0] == pytest.approx(0.5 + 1.0 * (PERIOD + 0.005))


def test_a_short_pause_of_the_controller_is_not_the_sensors_silence_but_restarts_the_reference():
    c = tracking()
    # Paused 6 periods (< max_reading_age_s): readings held back count as on their way.
    out = run(c, [22], readings=False)[0]
    assert out.status is Status.REACQUIRING and out.reference_source is ReferenceSource.REACQUIRE_BLEND
    c = tracking(max_reading_age_s=0.05)  # the same pause now longer than a reading may be old
    assert run(c, [22], readings=False)[0].status is Status.WATCHDOG


# --- the estimate at the tick ------------------------------------------------------------


def test_estimate_without_latency_compensation_is_the_reading():
    c = JointController(config(latency_compensation=False), 1)
    c.set_measurement(0.0, 0.0625, one(1.0), one(2.0))
    position, velocity = c._estimate_at_tick(0.0625)
    assert position[0] == 1.0 and velocity[0] == 2.0


def test_estimate_with_latency_compensation_advances_the_reading_to_the_tick():
    c = JointController(config(latency_compensation=True), 1)
    c.set_measurement(0.0, 0.0625, one(1.0), one(2.0))
    assert c._estimate_at_tick(0.0625)[0][0] == pytest.approx(1.125)  # 1 rad + 2 rad/s · 62.5 ms
    assert c._estimate_at_tick(0.25)[0][0] == pytest.approx(1.2)  # at most 0.1 s ahead
    assert c._estimate_at_tick(-0.5)[0][0] == 1.0  # never back in time
    c.set_reference(0.0625, one(1.0), one(0), one(0))
    assert c.update(0.0625).measured[0] == pytest.approx(1.125)


def test_latency_compensation_on_the_arm_model_under_the_commands_issued():
    c = JointController(config(latency_compensation=True), 1, arm())
    c.set_measurement(0.0, 0.03125, one(0.2), one(0.5))
    position, velocity = c._estimate_at_tick(0.03125)
    expected = arm().predict(one(0.2), one(0.5), np.zeros(1), 0.03125)  # no command issued yet
    assert position[0] == pytest.approx(expected[0][0]) and velocity[0] == pytest.approx(expected[1][0])
    assert abs(position[0] - (0.2 + 0.5 * 0.03125)) > 1e-6  # gravity acted: not the reading's own velocity


# --- the reference at the tick ----------------------------------------------------------


def test_between_samples_the_output_says_whether_the_reference_was_extrapolated():
    c = tracking(speed=1.0, reference_extrapolation=True)
    outs = run(c, range(18, 22), speed=1.0, every=2)  # samples on even ticks
    assert [out.reference_source for out in outs] == [ReferenceSource.TRAJECTORY, ReferenceSource.EXTRAPOLATED] * 2
    assert outs[1].reference[0] == pytest.approx(19 * PERIOD)  # the ramp, one period on from its sample
    c = tracking(speed=1.0, reference_extrapolation=False)
    outs = run(c, range(18, 22), speed=1.0, every=2)
    assert all(out.reference_source is ReferenceSource.TRAJECTORY for out in outs)
    assert outs[1].reference[0] == pytest.approx(18 * PERIOD)  # the sample held


def test_hold_before_the_first_reference_is_reported():
    c = JointController(config(), 1)
    outs = run(c, range(3), planner=False, arm_at=0.3) + run(c, range(3, 6), planner=False, arm_at=0.5)
    for out in outs:
        assert out.status is Status.HOLDING and out.reference_source is ReferenceSource.HOLD_POSITION
        assert out.reference[0] == 0.3  # where the hold began, not where the arm drifted
    assert not c.has_reference() and not c.reference_ready(6 * PERIOD)


def test_a_stale_reference_is_brought_to_rest_and_held_then_blended_back():
    c = tracking(speed=1.0, reference_extrapolation=True)
    quiet = run(c, range(17, 40), speed=1.0, planner=False)
    # Fresh for max(5 planner periods, 0.1 s) after the last sample (tick 16): extrapolated meanwhile.
    assert all(out.status is Status.OK for out in quiet[:6])
    assert quiet[5].reference[0] == pytest.approx(22 * PERIOD)
    stop = quiet[6:]
    assert all(
        out.status is Status.REFERENCE_LOST and out.reference_source is ReferenceSource.REFERENCE_STOP for out in stop
    )
    # From the last reference carried on one period at 1 rad/s, to rest 0.025 rad further.
    assert stop[0].reference[0] == pytest.approx(23 * PERIOD)
    assert stop[-1].reference[0] == pytest.approx(23 * PERIOD + 0.025) == stop[-2].reference[0]
    back = run(c, range(40, 80), speed=1.0)
    assert back[0].status is Status.REACQUIRING and back[0].reference_source is ReferenceSource.REACQUIRE_BLEND
    assert back[0].reference[0] == pytest.approx(23 * PERIOD + 0.025)  # no jump onto the trajectory
    assert back[-1].status is Status.OK and back[-1].reference[0] == pytest.approx(79 * PERIOD)


def test_reference_ready_waits_for_the_samples_due():
    c = JointController(config(), 1)
    assert not c.reference_ready(0.0)
    c.set_reference(0.0, one(0), one(0), one(0), sample_time_s=0.0)
    c.set_reference(2 * PERIOD, one(0), one(0), one(0), sample_time_s=2 * PERIOD)
    assert c.reference_period_s == 2 * PERIOD
    assert c.reference_ready(2 * PERIOD) and c.reference_ready(3 * PERIOD)
    assert not c.reference_ready(4 * PERIOD)  # the next sample is due


# --- the law ---------------------------------------------------------------------------


def test_law_in_force_for_pid_gives_the_pid_gains():
    c = JointController(config(), 1)
    law = c.law_in_force()
    assert law.startswith("PID: Kp=[50] N·m/rad, Ki=[10] N·m/(rad·s), Kd=[5] N·m·s/rad")
    assert "unused" not in law and "\n" not in law


def test_law_in_force_for_lqr_gives_the_designed_gains_and_says_kp_ki_kd_are_unused():
    c = JointController(config(controller_type="lqr", lqr_q=(1e4, 1e4, 1.0), lqr_r=10.0, feedforward="full"), 1, arm())
    law, gains = c.law_in_force(), c.gains
    assert law.startswith("LQR (q=[1e+04, 1e+04, 1], r=10")
    for name, value in (("Kp", gains.kp[0]), ("Ki", gains.ki[0]), ("Kd", gains.kd[0])):
        assert f"{name}=[{value:.3g}]" in law
    assert gains.kp[0] != 50.0 and "Kp=[50]" not in law
    assert "kp/ki/kd parameters are unused" in law and "\n" not in law
    c.set_config(config(feedforward="full"))
    assert c.law_in_force().startswith("PID: Kp=[50]")


def test_the_law_is_feedback_plus_the_models_feedforward_within_the_limit():
    c = JointController(config(feedforward="full"), 1, arm())
    c.set_measurement(0.0, 0.0, one(0.1), one(0.0))
    reference = Reference(one(0.12), one(0.5), one(2.0))
    out = c._apply_law(0.0, one(0.1), one(0.0), reference)
    assert out.terms.feedforward[0] == pytest.approx(arm().torque(one(0.12), one(0.5), one(2.0))[0])
    assert out.terms.p[0] == pytest.approx(50 * 0.02)
    expected = out.terms.feedforward + out.terms.p + out.terms.i + out.terms.d
    assert out.command[0] == pytest.approx(np.clip(expected, -TORQUE_MAX, TORQUE_MAX)[0])
    far = Reference(one(5.0), one(0.0), one(0.0))
    assert c._apply_law(PERIOD, one(0.1), one(0.0), far).command[0] == TORQUE_MAX


def test_control_output_keeps_its_five_field_constructor():
    zeros = np.zeros(1)
    out = ControlOutput(
        0.0, Status.OK, one(1.0), one(0.5), PidTerms(zeros, zeros, zeros, zeros, zeros, np.zeros(1, dtype=bool))
    )
    assert out.reference_source is ReferenceSource.TRAJECTORY and out.error[0] == 0.5


finite = st.floats(-1e4, 1e4, allow_nan=False, allow_infinity=False)
event = st.fixed_dictionaries(
    {
        "dt": st.floats(1e-4, 0.3),
        "reference": st.none() | st.tuples(finite, finite, finite),
        "reading": st.none() | st.tuples(st.floats(-0.2, 0.2), finite, finite),  # stamp offset, q, v
        "halt": st.sampled_from([False, False, False, True]),
        "brakes": st.sampled_from([False, False, False, True]),
    }
)


@settings(max_examples=80, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])
@given(law=st.sampled_from(["pid", "pid-model", "lqr"]), events=st.lists(event, min_size=1, max_size=25))
def test_output_is_finite_within_torque_max_and_says_when_the_reference_is_not_the_planners(law, events):
    if law == "pid":
        c = JointController(config(latency_compensation=True, reference_extrapolation=True), 1)
    else:
        c = JointController(
            config(
                controller_type="lqr" if law == "lqr" else "pid",
                feedforward="full",
                estimator=configs.kalman(),
                latency_compensation=True,
                reference_extrapolation=True,
            ),
            1,
            arm(),
        )
    t = 0.0
    for e in events:
        t += e["dt"]
        c.halt(e["halt"])
        c.brakes(e["brakes"])
        if e["reference"] is not None:
            c.set_reference(t, *(one(x) for x in e["reference"]), sample_time_s=t)
        if e["reading"] is not None:
            offset, q, v = e["reading"]
            c.set_measurement(t + offset, t, one(q), one(v))
        out = c.update(t)
        assert np.all(np.isfinite(out.command)) and np.all(np.abs(out.command) <= TORQUE_MAX)
        assert out.command.shape == out.reference.shape == out.measured.shape == (1,)
        if not out.status.commanding:
            assert np.all(out.command == 0.0) and out.reference_source is ReferenceSource.NONE
        assert (out.status is Status.OK) == out.reference_source.from_planner
