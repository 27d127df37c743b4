"""Control laws as plugins: how a law is named and built, its parameters, and
how the controller contains one that raises, returns a bad torque or overruns."""

from __future__ import annotations

import numpy as np
import pytest

from robot_controller import parameters as cfg
from robot_controller.core.controller import JointController
from robot_controller.core.controller.supervision import Status
from robot_controller.core.errors import ConfigError
from robot_controller.core.laws import Arm, ControlLaw, LqrLaw, Parameter, PidLaw, registry
from robot_controller.core.laws.containment import ContainedLaw
from robot_controller.experiments.inprocess import simulate

EXAMPLE = "examples/own_controller.py:PDWithGravity"


def stack(controller_type: str, robot: str = "one_dof", **law_values) -> cfg.Params:
    params = cfg.load_stack("default", None, robot)
    params["pid_controller"]["controller_type"] = controller_type
    params["pid_controller"].update({f"law.{k}": v for k, v in law_values.items()})
    return params


def controller(params: cfg.Params, clock=None) -> JointController:
    from robot_controller.parameters.builders import arm_model

    ctrl = params["pid_controller"]
    dynamics = arm_model(ctrl)
    n = len(dynamics.joint_names)
    return JointController(cfg.controller_config(ctrl, n), n, dynamics, law_clock=clock)


# --- naming -----------------------------------------------------------------------------


def test_the_builtin_laws_resolve_through_the_entry_point_group():
    assert registry.resolve("pid") is PidLaw
    assert registry.resolve("lqr") is LqrLaw
    assert set(registry.installed_laws()) >= {"pid", "lqr"}


def test_a_law_is_named_by_file_or_by_module():
    by_file = registry.resolve(EXAMPLE)
    by_module = registry.resolve("tests.core.laws.law_fixtures:Counting")
    assert by_file.__name__ == "PDWithGravity" and issubclass(by_file, ControlLaw)
    assert by_module.__name__ == "Counting" and issubclass(by_module, ControlLaw)


@pytest.mark.parametrize(
    ("spec", "says"),
    [
        ("sliding_mode", "is not an installed law"),
        ("nowhere/law.py:Law", "no such file"),
        ("examples/own_controller.py:Missing", "has no 'Missing'"),
        ("robot_controller.no_such_module:Law", "failed to load: ModuleNotFoundError"),
        ("numpy:pi", "not a class with an update() method"),
        ("examples/own_controller.py:not-a-name", "is not a class name"),
    ],
)
def test_a_spec_that_names_no_law_is_refused_in_one_line(spec, says):
    with pytest.raises(ConfigError) as refused:
        registry.resolve(spec)
    assert says in str(refused.value) and "\n" not in str(refused.value)


def test_a_law_that_fails_to_import_is_refused_with_its_error(tmp_path):
    broken = tmp_path / "broken.py"
    broken.write_text("raise RuntimeError('no licence for this law')\n")
    with pytest.raises(ConfigError, match="RuntimeError: no licence for this law"):
        registry.resolve(f"{broken}:Law")


# --- parameters -------------------------------------------------------------------------


def test_declared_parameters_take_their_defaults_and_the_values_given():
    c = controller(stack(EXAMPLE, natural_frequency_hz=5.0))
    assert c.plugin.law.params == {"natural_frequency_hz": 5.0, "damping_ratio": 1.0}
    assert "natural_frequency_hz=5" in c.law_in_force()


@pytest.mark.parametrize(
    ("values", "says"),
    [
        ({"natural_frequency_hz": 100.0}, "law.natural_frequency_hz: must be <= 30"),
        ({"natural_frequency_hz": "fast"}, "law.natural_frequency_hz: expected a number"),
        ({"stiffness": 1.0}, "law.stiffness: PDWithGravity declares no such parameter"),
        ({"damping_ratio": [1.0, 2.0]}, "law.damping_ratio: expected one number"),
    ],
)
def test_a_bad_parameter_value_is_refused_naming_it(values, says):
    with pytest.raises(ConfigError, match=says):
        controller(stack(EXAMPLE, **values))


def test_parameters_change_while_running_and_are_checked_first():
    params = stack(EXAMPLE)
    c = controller(params)
    ctrl = dict(params["pid_controller"], **{"law.damping_ratio": 0.7})
    c.set_config(cfg.controller_config(ctrl, 1))
    assert c.plugin.law.params["damping_ratio"] == 0.7
    with pytest.raises(ConfigError, match="law.damping_ratio"):
        c.set_config(cfg.controller_config(dict(ctrl, **{"law.damping_ratio": -1.0}), 1))
    assert c.plugin.law.params["damping_ratio"] == 0.7
    with pytest.raises(ConfigError, match="chosen when the controller starts"):
        c.set_config(cfg.controller_config(dict(ctrl, controller_type="lqr"), 1))


def test_a_law_whose_constructor_raises_is_refused_at_start(tmp_path):
    law = tmp_path / "law.py"
    law.write_text(
        "from robot_controller.core.laws import ControlLaw\n"
        "class Law(ControlLaw):\n"
        "    def __init__(self, arm, period_s, params):\n"
        "        raise ValueError('needs two joints')\n"
    )
    with pytest.raises(ConfigError, match="failed to start: ValueError: needs two joints"):
        controller(stack(f"{law}:Law"))


def test_a_declared_default_outside_its_own_range_is_the_laws_bug():
    class Bad(ControlLaw):
        parameters = (Parameter("gain", 5.0, "", minimum=10.0),)

    from robot_controller.core.laws import law_parameters as parameters

    with pytest.raises(ConfigError, match="law.gain: must be >= 10"):
        parameters.values(Bad, {}, 1)


# --- the loop ---------------------------------------------------------------------------


@pytest.mark.parametrize("robot", ["one_dof", "planar2"])
def test_the_example_tracks_the_reference_scenario(robot):
    result = simulate(stack(EXAMPLE, robot), duration_s=8.0)
    assert result.law_fault is None
    assert result.tracking_metrics()["tracking_rms_rad"] < 0.02


def test_the_law_is_reset_on_every_start_and_reports_its_terms():
    c = controller(stack("tests.core.laws.law_fixtures:Counting"))
    c.set_reference(0.0, np.array([0.1]), np.zeros(1), np.zeros(1), 0.0)
    for k in range(5):
        c.set_measurement(k * 0.01, k * 0.01, np.zeros(1), np.zeros(1))
        out = c.update(k * 0.01)
    assert c.plugin.law.resets == 1
    assert out.law_terms == {"gravity": pytest.approx(np.ones(1))}
    assert out.terms.p[0] == 2.0


def test_the_framework_clips_the_laws_torque_to_the_limit(tmp_path):
    law = tmp_path / "law.py"
    law.write_text(
        "import numpy as np\n"
        "from robot_controller.core.laws import ControlLaw\n"
        "class Law(ControlLaw):\n"
        "    def update(self, time_s, state, reference):\n"
        "        return np.full(self.arm.joint_count, 1e6)\n"
    )
    c = controller(stack(f"{law}:Law"))
    c.set_reference(0.0, np.zeros(1), np.zeros(1), np.zeros(1), 0.0)
    c.set_measurement(0.0, 0.0, np.zeros(1), np.zeros(1))
    out = c.update(0.0)
    assert out.command[0] == pytest.approx(c.config.pid.output_limit[0]) and out.terms.saturated[0]


@pytest.mark.parametrize(
    ("law", "says"),
    [
        ("RaisesAfter", "raised ZeroDivisionError: the law divided by zero"),
        ("NaNAfter", "returned a non-finite torque"),
        ("WrongShapeAfter", "returned a torque of shape (2,), expected (1,)"),
    ],
)
def test_a_failing_law_is_stopped_on_the_builtin_law_and_the_arm_stays_in_its_band(law, says):
    params = stack(f"tests.core.laws.law_fixtures:{law}", fail_after_s=3.0)
    result = simulate(params, duration_s=6.0)
    assert result.law_fault is not None and says in result.law_fault and "at t = 3.000 s" in result.law_fault
    planned = result.reference[result.tick_time_s < 3.0]
    low, high = planned.min() - 0.1, planned.max() + 0.1
    assert np.all((result.true_position >= low) & (result.true_position <= high))
    # After the stop and its hold, no more torque: the brakes hold the arm where it stopped.
    assert np.all(result.command[-50:] == 0.0)
    assert np.ptp(result.true_position[-50:]) < 1e-3


def test_a_law_that_pushes_the_arm_away_is_stopped_before_it_leaves_its_band():
    # Finite torques, in shape and in time, that swing the arm: only the error from the reference shows it.
    law = "tests.core.laws.law_fixtures:PushesAwayAfter"
    params = stack(law, fail_after_s=3.0)
    params["pid_controller"]["law_error_max_rad"] = 0.0
    unchecked = simulate(params, duration_s=6.0)
    assert unchecked.law_fault is None and unchecked.true_position.max() > 2.0  # swung far out of ±1 rad
    result = simulate(stack(law, fail_after_s=3.0), duration_s=6.0)
    assert "let the arm run away from its reference" in result.law_fault and "law_error_max_rad 0.5" in result.law_fault
    assert np.all(np.abs(result.true_position) <= 1.1)
    assert np.all(result.command[-50:] == 0.0) and np.ptp(result.true_position[-50:]) < 1e-3


def test_a_reference_that_jumps_is_no_runaway():
    # A square wave's 1 rad jumps leave the arm far from the reference, at rest: the law brings it back.
    params = stack(EXAMPLE)
    params["trajectory_planner"].update({"mode": "square", "amplitude": [0.5]})
    result = simulate(params, duration_s=4.0)
    assert result.law_fault is None
    assert np.max(np.abs(result.reference - result.true_position[:, 0])) > 0.9  # the jumps were there


def test_the_laws_budget_and_error_limit_change_while_it_runs():
    from dataclasses import replace

    c = controller(stack(EXAMPLE))
    c.set_config(replace(c.config, law_budget_s=0.02, law_error_max_rad=0.2))
    assert (c.plugin.budget_s, c.plugin.error_max_rad) == (0.02, 0.2)


def test_a_law_over_its_budget_tick_after_tick_is_a_fault_one_long_call_is_not():
    import itertools

    class Instant:
        def update(self, time_s, state, reference):
            return np.zeros(1)

    arm = Arm(None, ("joint 1",), np.array([np.inf]), np.array([[-np.inf, np.inf]]))
    wall = itertools.count(0.0, 0.001)  # each reading of the clock 1 ms after the last: 1 ms per call
    law = ContainedLaw(Instant(), "Instant", arm, 0.01, {}, clock=lambda: next(wall), budget_s=0.0005)
    assert isinstance(law.update(1.0, None, None), np.ndarray) and law.fault is None
    assert isinstance(law.update(1.01, None, None), np.ndarray) and law.fault is None
    law.update(1.02, None, None)
    fault = law.fault
    assert "took 1.0, 1.0, 1.0 ms in update() on 3 ticks running, over its budget of 0.5 ms" in fault.line()
    assert "at t = 1.020 s" in fault.line()
    law.update(1.03, None, None)
    assert law.fault is fault  # never called again

    calls = iter([0.0, 0.002, 0.0, 0.0001, 0.0, 0.002, 0.0, 0.0001])  # long, short, long, short
    patient = ContainedLaw(Instant(), "Instant", arm, 0.01, {}, clock=lambda: next(calls), budget_s=0.0005)
    assert all(isinstance(patient.update(t, None, None), np.ndarray) for t in (1.0, 1.01, 1.02, 1.03))
    assert patient.fault is None


def test_a_slow_law_is_stopped_in_the_loop_when_the_controller_has_a_clock():
    import time

    params = stack("tests.core.laws.law_fixtures:SlowAfter", fail_after_s=0.5)
    c = controller(params, clock=time.perf_counter)
    c.set_reference(0.0, np.zeros(1), np.zeros(1), np.zeros(1), 0.0)
    statuses = []
    for k in range(150):
        c.set_measurement(k * 0.01, k * 0.01, np.zeros(1), np.zeros(1))
        statuses.append(c.update(k * 0.01).status)
    assert "over its budget" in c.law_fault.line()
    assert Status.LAW_FAULT in statuses and statuses[-1] is Status.LAW_STOPPED


def test_the_builtin_laws_run_through_the_same_interface():
    params = stack("lqr")
    c = controller(params)
    from robot_controller.core.laws.interface import Reference, State

    zeros = np.zeros(1)
    torque = c.stop_law.update(0.0, State(zeros, zeros, zeros, zeros, zeros), Reference(zeros + 0.1, zeros, zeros))
    assert torque.shape == (1,) and torque[0] > 0
