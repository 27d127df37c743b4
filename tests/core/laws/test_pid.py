"""The PID law alone: terms, limits, anti-windup, guards (no ROS, no sleeping)."""

import numpy as np
import pytest

from robot_controller.core.errors import ConfigError
from robot_controller.core.laws.pid import AntiWindup, DerivativeSource, Pid
from tests.core import configs

DT = 0.01


def make(**kw):
    return Pid(configs.pid(**kw))


def step(pid, r=0.0, y=0.0, rv=0.0, yv=0.0, ff=0.0, dt=DT):
    a = lambda x: np.array([x], dtype=float)  # noqa: E731
    return pid.step(dt, a(r), a(rv), a(y), a(yv), ff)


def test_terms_of_one_step_match_the_formula():
    pid = make(derivative_source="velocity_error")
    out = step(pid, r=0.1, y=0.02, rv=0.5, yv=0.3, ff=0.25)
    assert out.p[0] == pytest.approx(50 * 0.08)
    assert out.i[0] == pytest.approx(10 * 0.08 * DT)
    assert out.d[0] == pytest.approx(5 * 0.2)
    assert out.feedforward[0] == pytest.approx(0.25)
    assert out.command[0] == pytest.approx(out.p[0] + out.i[0] + out.d[0] + 0.25)
    assert not out.saturated[0]


def test_tutorial_derivative_is_minus_measured_velocity():
    out = step(make(derivative_source="measured_velocity"), r=0.0, y=0.0, rv=3.0, yv=0.4)
    assert out.d[0] == pytest.approx(-5 * 0.4)


@pytest.mark.parametrize("source", ["error", "measurement"])
def test_finite_difference_derivatives(source):
    pid = make(derivative_source=source, ki=[0.0])
    step(pid, r=1.0, y=0.0)
    out = step(pid, r=1.0, y=0.01)  # measurement moved up 0.01 in one period
    assert out.d[0] == pytest.approx(-5 * 0.01 / DT)


def test_derivative_filter_smooths_a_jump():
    raw = make(derivative_source="measured_velocity")
    filtered = make(derivative_source="measured_velocity", derivative_filter_time_s=0.05)
    step(raw, yv=0.0), step(filtered, yv=0.0)
    assert abs(step(filtered, yv=1.0).d[0]) < abs(step(raw, yv=1.0).d[0]) / 3


def test_output_is_saturated_and_flagged():
    out = step(make(), r=5.0, y=0.0)
    assert out.command[0] == pytest.approx(10.0)
    assert out.saturated[0]


def test_slew_rate_limit():
    pid = make(slew_rate_limit=100.0)  # 1 N·m per 10 ms period
    step(pid, r=0.0)
    assert step(pid, r=1.0).command[0] == pytest.approx(1.0)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_input_gives_zero_and_keeps_state(bad):
    pid = make()
    step(pid, r=0.1)
    before = pid.integral_term.copy()
    out = step(pid, r=bad)
    assert out.command[0] == 0.0 and np.all(np.isfinite(out.command))
    np.testing.assert_array_equal(pid.integral_term, before)


def test_bumpless_gain_change_keeps_the_output_continuous():
    pid = make(kp=[0.0], kd=[0.0], ki=[10.0])
    for _ in range(50):
        last = step(pid, r=0.2).command[0]
    pid.set_config(configs.pid(kp=[0.0], kd=[0.0], ki=[40.0]))
    after = step(pid, r=0.2).command[0]
    assert abs(after - last) < 40 * 0.2 * DT * 1.01  # only one period's integration, no jump


def test_batch_of_gain_sets_broadcasts():
    pid = Pid(configs.pid(kp=[10.0, 20.0, 30.0], ki=[0.0], kd=[0.0], output_limit=[100.0]))
    out = pid.step(DT, np.ones(3), np.zeros(3), np.zeros(3), np.zeros(3))
    np.testing.assert_allclose(out.command, [10, 20, 30])


@pytest.mark.parametrize(
    "kwargs, key",
    [
        (dict(kp=[-1.0]), "kp"),
        (dict(ki=[np.nan]), "ki"),
        (dict(output_limit=[0.0]), "output_limit"),
        (dict(anti_windup="sometimes"), "anti_windup"),
        (dict(derivative_source="x"), "derivative_source"),
        (dict(derivative_filter_time_s=-1.0), "derivative_filter_time_s"),
    ],
)
def test_invalid_config_names_the_key(kwargs, key):
    with pytest.raises(ConfigError, match=key):
        make(**kwargs)


def _saturated_plant_run(mode):
    """A unit-inertia plant with a torque limit too small to follow a 1 rad step at first.

    Returns the overshoot past the target, rad.
    """
    pid = make(
        kp=[20.0],
        ki=[20.0],
        kd=[8.0],
        output_limit=[2.0],
        integral_limit=[0.05],
        anti_windup=mode,
        derivative_source="measured_velocity",
        back_calculation_time_s=0.05,
    )
    q = v = 0.0
    peak = 0.0
    for _ in range(800):
        u = step(pid, r=1.0, y=q, yv=v).command[0]
        assert abs(u) <= 2.0 + 1e-12
        v += u * DT
        q += v * DT
        peak = max(peak, q)
    return peak - 1.0, q


@pytest.mark.parametrize("mode", [m.value for m in AntiWindup])
def test_every_anti_windup_mode_settles_and_limits_windup(mode):
    overshoot, final = _saturated_plant_run(mode)
    assert abs(final - 1.0) < 0.05
    if mode != "none":
        assert overshoot < _saturated_plant_run("none")[0]


def test_anti_windup_modes_beat_no_protection_clearly():
    none = _saturated_plant_run("none")[0]
    assert _saturated_plant_run("back_calculation")[0] < 0.5 * none
    assert _saturated_plant_run("conditional_integration")[0] < 0.5 * none
    assert DerivativeSource("velocity_error")  # the enum round-trips its value


def test_gains_given_as_one_value_on_a_chain_are_scaled_by_each_joints_inertia_a_list_per_joint_is_not():
    from robot_controller import parameters as cfg
    from robot_controller.core.controller import JointController, law_config
    from robot_controller.core.laws import lqr
    from robot_controller.parameters.builders import arm_model

    ctrl = dict(cfg.load_stack(robot="planar2")["pid_controller"], controller_type="pid")
    dynamics = arm_model(ctrl)
    config = cfg.controller_config(ctrl, 2)
    assert config.scaled_gains == ("kp", "ki", "kd")
    ratio = lqr.design_inertia(dynamics, 2, config.design_position) / ctrl["reference_inertia"]
    assert ratio[0] > 5 and ratio[1] < 1  # a heavy shoulder, a light elbow
    gains = law_config(config, dynamics, 2)
    np.testing.assert_allclose(gains.kp, 50.0 * ratio)
    np.testing.assert_allclose((gains.ki, gains.kd), (10.0 * ratio, 5.0 * ratio))
    np.testing.assert_array_equal(JointController(config, 2, dynamics).gains.kp, gains.kp)  # the law runs them
    own = cfg.controller_config(dict(ctrl, kp=[50.0, 40.0]), 2)  # the user's, joint by joint
    assert own.scaled_gains == ("ki", "kd")
    np.testing.assert_array_equal(law_config(own, dynamics, 2).kp, [50.0, 40.0])
    one = cfg.load_stack()["pid_controller"]  # one joint: its one value is its own, as given to the bit
    assert cfg.controller_config(one, 1).scaled_gains == ()


def test_the_lqr_is_designed_for_a_rated_payload_within_a_bound_the_pid_is_not():
    """rated_payload_kg raises each joint's design inertia by the load's worst (payload.inertia_bound), at most
    PAYLOAD_INERTIA_RATIO × its own: the Panda's last wrist gets that cap, the LQR's gains grow with it."""
    from robot_controller import parameters as cfg
    from robot_controller.core.controller import law_config
    from robot_controller.core.laws.pid import PAYLOAD_INERTIA_RATIO, design_inertia
    from robot_controller.core.model.payload import inertia_bound
    from robot_controller.parameters.builders import arm_model

    ctrl = cfg.load_stack(robot="panda")["pid_controller"]
    dynamics, pose = arm_model(ctrl), tuple(ctrl["design_position"])
    own, loaded = design_inertia(dynamics, 7, pose), design_inertia(dynamics, 7, pose, 3.0)
    np.testing.assert_allclose(loaded, np.minimum(own + inertia_bound(dynamics.model, 3.0, np.array(pose)), 4 * own))
    assert PAYLOAD_INERTIA_RATIO == 4.0 and loaded[6] == pytest.approx(4 * own[6]) and np.all(loaded > own)
    unloaded, rated = (cfg.controller_config(dict(ctrl, lockstep=lockstep), 7) for lockstep in (False, True))
    assert (unloaded.rated_payload_kg, rated.rated_payload_kg) == (0.0, 3.0)  # lockstep only
    assert np.all(law_config(rated, dynamics, 7).kp > 1.5 * law_config(unloaded, dynamics, 7).kp)
    for config in (unloaded, rated):
        pid = law_config(config, dynamics, 7, "pid")
        np.testing.assert_array_equal(pid.kp, law_config(unloaded, dynamics, 7, "pid").kp)


@pytest.mark.parametrize("controller_type", ["lqr", "pid"])
def test_the_gains_line_gives_a_prismatic_joint_its_own_units(controller_type):
    from robot_controller import parameters as cfg
    from robot_controller.core.controller import JointController
    from robot_controller.parameters.builders import arm_model

    params = cfg.load_stack(robot="scara")["pid_controller"] | {"controller_type": controller_type}
    line = JointController(cfg.controller_config(params, 3), 3, arm_model(params)).law_in_force()
    gains = line.split(": ", 1)[1]
    assert gains.startswith("Kp=[") and " N·m/rad, " in gains and " N/m]" in gains, gains
    assert ", |torque| <= [30 N·m, 10 N·m, 40 N], " in gains, gains
    assert " N·m·s/rad, " in gains and " N·s/m]" in gains and " N/(m·s)]" in gains, gains
