"""Safety settings: every timeout and limit that protects the arm is read-only at run time and has
its bound; a config past a bound is refused at start naming the key and the bound."""

import pytest

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError

# node, parameter, the bound that holds it (maximum, or None where the bound is elsewhere or from below)
SAFETY_SETTINGS = [
    ("motor_node", "command_timeout_s", 0.2),
    ("motor_node", "max_command_age_s", 0.2),
    ("motor_node", "torque_max", None),  # the URDF's effort limit (consistency)
    ("simulator", "drive_timeout_s", 0.2),
    ("simulator", "brake_torque_nm", None),  # > 0: a stronger brake only holds better
    ("pid_controller", "watchdog_periods", 20),
    ("pid_controller", "sensor_timeout_s", 1.0),
    ("pid_controller", "max_reading_age_s", 0.2),
    ("pid_controller", "law_budget_s", 0.05),
    ("pid_controller", "law_error_max_rad", 1.0),
    ("pid_controller", "stop_deceleration", None),  # at least 1 rad/s²
    ("pid_controller", "reacquire_acceleration", 100.0),
    ("pid_controller", "min_delay_margin_periods", None),  # more only refuses more gains
]


def test_the_safety_settings_are_these_read_only_and_bounded():
    found = {(node, spec.name) for node in cfg.NODES for spec in cfg.SCHEMA[node] if spec.safety}
    assert found == {(node, name) for node, name, _ in SAFETY_SETTINGS}
    for node, name, maximum in SAFETY_SETTINGS:
        spec = cfg.spec_of(node, name)
        assert spec.read_only and spec.maximum == maximum, (node, name)
        assert spec.refusal == "safety setting: set it in the run's config, not at run time"


@pytest.mark.parametrize(("node", "name", "maximum"), [s for s in SAFETY_SETTINGS if s[2] is not None])
def test_a_value_past_a_safety_bound_is_refused_naming_the_key_and_the_bound(node, name, maximum):
    spec = cfg.spec_of(node, name)
    assert spec.validate(maximum) == maximum
    too_far = maximum + 1 if spec.kind is int else maximum * 1.01
    with pytest.raises(ConfigError, match=rf"^{name}: must be <= {maximum:g} \(a safety setting's bound\)"):
        spec.validate(too_far)


def test_a_stop_deceleration_that_would_not_stop_is_refused():
    with pytest.raises(ConfigError, match="stop_deceleration: must be >= 1, got 0.01"):
        cfg.spec_of("pid_controller", "stop_deceleration").validate(0.01)


def test_a_config_file_past_a_bound_is_refused_at_start_naming_the_file_key_and_bound(tmp_path):
    path = tmp_path / "lax.yaml"
    path.write_text("motor_node:\n  ros__parameters:\n    command_timeout_s: 10.0\n")
    with pytest.raises(ConfigError) as refused:
        cfg.load_stack(config=path)
    assert str(refused.value) == (
        f"{path}: motor_node.command_timeout_s: must be <= 0.2 (a safety setting's bound), got 10"
    )


def test_a_read_only_parameter_says_why_it_is_refused():
    assert cfg.spec_of("motor_node", "urdf_path").refusal.startswith("read-only: fixed when the node starts")
    assert not cfg.spec_of("pid_controller", "kp").safety  # gains stay live: tuning, not protection


def test_a_safety_setting_must_be_read_only():
    with pytest.raises(AssertionError, match="a safety setting is read-only"):
        cfg.ParamSpec("timeout_s", float, 0.05, "a timeout, s", maximum=0.2, safety=True)
