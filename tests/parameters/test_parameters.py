"""Parameter files: the shipped ones are complete and valid; bad ones name the key and the problem."""

import subprocess
import sys

import pytest

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError


@pytest.mark.parametrize("robot", ["one_dof", "planar2"])
def test_the_values_written_as_a_parameter_file_read_back_the_same(tmp_path, robot):
    written = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", "params", "--yaml", "--robot", robot],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    (tmp_path / "defaults.yaml").write_text(written)
    assert cfg.read_params_file(tmp_path / "defaults.yaml") == cfg.load_stack(robot=robot)


def test_an_empty_torque_limit_is_each_joints_urdf_effort_limit():
    params = cfg.load_stack(robot="planar2")
    for node in ("motor_node", "pid_controller", "trajectory_planner"):
        assert params[node]["torque_max"] == [30.0, 10.0]
    assert cfg.load_stack()["motor_node"]["torque_max"] == [10.0]  # the reference arm's 10 N·m


def test_a_torque_limit_above_the_urdf_effort_limit_is_refused(tmp_path):
    from robot_controller.parameters import consistency

    path = tmp_path / "over.yaml"
    path.write_text("/**:\n  ros__parameters:\n    torque_max: [40.0, 10.0]\n")
    with pytest.raises(ConfigError, match=r"torque_max \[40\.0, 10\.0\] N·m exceeds the URDF's effort limit"):
        consistency.check_stack(cfg.load_stack(config=path, robot="planar2"))


def test_later_config_files_override_earlier_ones(tmp_path):
    first, second = tmp_path / "first.yaml", tmp_path / "second.yaml"
    first.write_text("pid_controller:\n  ros__parameters:\n    kp: 1.0\n    ki: 2.0\n")
    second.write_text("pid_controller:\n  ros__parameters:\n    kp: 3.0\n")
    values = cfg.load_stack("default", [first, second])["pid_controller"]
    assert (values["kp"], values["ki"]) == (3.0, 2.0)


def test_a_default_that_breaks_its_own_rule_is_caught_at_definition():
    with pytest.raises(ConfigError, match="rate: must be <= 10"):
        cfg.ParamSpec("rate", float, 20.0, "a rate, Hz", maximum=10.0)


def test_a_fixed_length_list_refuses_another_length():
    with pytest.raises(ConfigError, match="lqr_q: expected 3 values, got 2"):
        cfg.spec_of("pid_controller", "lqr_q").validate([1.0, 2.0])


def test_every_parameter_has_a_description():
    for node in cfg.NODES:
        for spec in cfg.SCHEMA[node]:
            assert len(spec.description) > 10, f"{node}.{spec.name}"


@pytest.mark.parametrize("preset", cfg.available_presets())
def test_presets_load(preset):
    params = cfg.load_stack(preset)
    cfg.controller_config(params["pid_controller"], 1)


def test_tutorial_preset_is_the_tutorials_controller():
    c = cfg.load_stack("tutorial")["pid_controller"]
    assert (c["kp"], c["ki"], c["kd"], c["integral_limit"]) == ([50.0], [10.0], [5.0], [10.0])
    assert c["derivative_source"] == "measured_velocity" and c["feedforward"] == "none"
    assert cfg.load_stack("tutorial")["trajectory_planner"]["publish_rate_hz"] == 20.0


@pytest.mark.parametrize(
    "text, expected",
    [
        ("pid_controller:\n  ros__parameters:\n    kp: -3.0\n", r"pid_controller\.kp: must be >= 0"),
        (
            "pid_controller:\n  ros__parameters:\n    kpp: 3.0\n",
            r"pid_controller\.kpp: unknown parameter \(did you mean 'kp'\?\)",
        ),
        ("pid_controler:\n  ros__parameters:\n    kp: 3.0\n", r"unknown node 'pid_controler'"),
        ("pid_controller:\n  ros__parameters:\n    anti_windup: maybe\n", r"anti_windup: 'maybe' is not one of"),
        ("pid_controller:\n  ros__parameters:\n    kd: .nan\n", r"kd: must be finite"),
        ("sensor_node:\n  ros__parameters:\n    rate_hz: fast\n", r"sensor_node\.rate_hz: expected a number"),
        ("pid_controller:\n  kp: 3.0\n", r"expected exactly one key 'ros__parameters'"),
        ("pid_controller: [\n", r"not valid YAML"),
    ],
)
def test_bad_config_names_key_and_problem(tmp_path, text, expected):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError, match=expected):
        cfg.load_stack("default", path)


def test_wildcard_and_layering(tmp_path):
    path = tmp_path / "mine.yaml"
    path.write_text(
        "/**:\n  ros__parameters:\n    use_sim_time: false\n    torque_max: [5.0]\n"
        "pid_controller:\n  ros__parameters:\n    kp: 80\n"
    )
    params = cfg.load_stack("tutorial", path)
    assert params["pid_controller"]["kp"] == 80.0
    assert params["motor_node"]["torque_max"] == [5.0] and params["pid_controller"]["torque_max"] == [5.0]
    assert params["pid_controller"]["derivative_source"] == "measured_velocity"  # the preset stays


def test_written_params_file_reads_back(tmp_path):
    params = cfg.load_stack()
    again = cfg.read_params_file(cfg.write_params_file(params, tmp_path / "p.yaml"))
    assert again == params


def test_cli_reports_a_bad_config_and_exits_2(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("pid_controller:\n  ros__parameters:\n    ki: -1\n")
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", "run", "--config", str(path)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2
    assert "pid_controller.ki: must be >= 0" in proc.stderr


def test_a_param_dump_reads_back_as_a_config(tmp_path):
    """What ``robot-controller param dump`` writes (rclpy's built-ins, the reported law, unset lists as null)."""
    dump = tmp_path / "dump.yaml"
    dump.write_text(
        "/pid_controller:\n  ros__parameters:\n    kp: [60.0]\n    use_sim_time: false\n"
        "    start_type_description_service: true\n    law_in_force: 'LQR (q=...)'\n"
        "    model_inertia: null\n"
    )
    values = cfg.load_stack("default", [dump])["pid_controller"]
    assert values["kp"] == [60.0] and "law_in_force" not in values


def test_a_run_plan_gives_the_planner_the_controllers_arm_model(tmp_path):
    """``identified.yaml`` sets only the controller's ``model_*``: the planner node gets the same values
    in the run's parameter file, so it checks its trajectory against the arm the controller models."""
    from robot_controller.parameters import consistency
    from robot_controller.parameters.builders import MODEL_KEYS, arm_model
    from robot_controller.runner import plan
    from robot_controller.runner.options import RunOptions

    overlay = tmp_path / "identified.yaml"
    overlay.write_text(
        "pid_controller:\n  ros__parameters:\n    model_inertia: [1.0]\n    model_gravity_torque: [2.0]\n"
    )
    params = cfg.load_stack("default", [overlay])
    assert params["trajectory_planner"]["model_inertia"] == []  # nothing set for the planner itself
    run = plan.plan(plan.check(params, RunOptions(sim_time=True)), tmp_path / "run")
    written = cfg.read_params_file(tmp_path / "run" / "params.yaml")
    assert "&id" not in (tmp_path / "run" / "params.yaml").read_text()  # no YAML alias: rcl refuses them
    for key in MODEL_KEYS:
        assert written["trajectory_planner"][key] == written["pid_controller"][key] == params["pid_controller"][key]
    planner_model = arm_model(written["trajectory_planner"])
    assert planner_model.describe() == arm_model(params["pid_controller"]).describe()
    assert "inertia [1]" in planner_model.describe()
    assert all(str(tmp_path / "run" / "params.yaml") in node.args for node in run.nodes)
    # The check before start plans on that model too: the sine slowed (on the URDF alone it is left).
    assert "scaled in time" in consistency.trajectory_plan(params).warning
    assert params["trajectory_planner"]["model_inertia"] == []  # the caller's values are left as they were


def test_planner_model_values_that_disagree_with_the_controllers_are_refused(tmp_path):
    from robot_controller.parameters import consistency
    from robot_controller.runner import plan
    from robot_controller.runner.options import RunOptions

    params = cfg.load_stack("default")
    params["pid_controller"]["model_inertia"] = [0.2]
    params["trajectory_planner"]["model_inertia"] = [0.2]  # the same: accepted
    consistency.check_stack(params)
    params["trajectory_planner"]["model_inertia"] = [0.3]
    with pytest.raises(ConfigError) as refused:
        consistency.check_stack(params)
    message = str(refused.value)
    assert "\n" not in message
    assert message.startswith(
        "trajectory_planner: model_inertia [0.3] differs from pid_controller's [0.2], the arm model its trajectory "
        "is checked against"
    ), message
    with pytest.raises(ConfigError, match=r"^trajectory_planner: model_inertia \[0\.3\] differs"):
        plan.check(params, RunOptions())
    assert not (tmp_path / "run").exists()
    # Set for the planner alone, the controller on its URDF: refused too.
    params["pid_controller"]["model_inertia"] = []
    params["trajectory_planner"].update(model_inertia=[], model_damping=[0.5])
    with pytest.raises(ConfigError, match=r"model_damping \[0\.5\] differs from pid_controller's \[\] \(the URDF's\)"):
        consistency.check_stack(params)
    # Set once for every node: the same on both, accepted.
    everyone = tmp_path / "everyone.yaml"
    everyone.write_text("/**:\n  ros__parameters:\n    model_damping: [0.5]\n")
    both = cfg.load_stack("default", [everyone])
    assert both["trajectory_planner"]["model_damping"] == both["pid_controller"]["model_damping"] == [0.5]
    consistency.check_stack(both)


def test_a_run_whose_gains_leave_a_joint_no_delay_margin_is_refused_at_start(tmp_path):
    from robot_controller.parameters import consistency

    path = tmp_path / "stiff.yaml"
    path.write_text("pid_controller:\n  ros__parameters:\n    controller_type: pid\n    kp: [50.0, 2000.0]\n")
    with pytest.raises(ConfigError, match=r"pid_controller: controller_type pid: .* joint elbow a delay margin of 0"):
        consistency.check_stack(cfg.load_stack(config=path, robot="planar2"))


@pytest.mark.parametrize(
    "text",
    [
        "pid_controller:\n  ros__parameters:\n    control_rate_hz: 50.0\n",
        "simulator:\n  ros__parameters:\n    control_rate_hz: 50.0\n",
        "/**:\n  ros__parameters:\n    control_rate_hz: 50.0\n",
    ],
)
def test_the_loop_has_one_control_rate_set_on_any_node(tmp_path, text):
    path = tmp_path / "rate.yaml"
    path.write_text(text)
    params = cfg.load_stack("default", path)
    assert params["simulator"]["control_rate_hz"] == params["pid_controller"]["control_rate_hz"] == 50.0


def test_a_later_file_sets_the_loops_rate_on_either_node(tmp_path):
    slow, fast = tmp_path / "slow.yaml", tmp_path / "fast.yaml"
    slow.write_text("pid_controller:\n  ros__parameters:\n    control_rate_hz: 50.0\n")
    fast.write_text("simulator:\n  ros__parameters:\n    control_rate_hz: 200.0\n")
    params = cfg.load_stack("default", [slow, fast])
    assert params["simulator"]["control_rate_hz"] == params["pid_controller"]["control_rate_hz"] == 200.0


def test_two_control_rates_for_one_loop_are_refused_naming_the_key(tmp_path):
    from robot_controller.parameters import consistency

    path = tmp_path / "two.yaml"
    path.write_text(
        "pid_controller:\n  ros__parameters:\n    control_rate_hz: 50.0\n"
        "simulator:\n  ros__parameters:\n    control_rate_hz: 200.0\n"
    )
    with pytest.raises(
        ConfigError,
        match=r"two.yaml: simulator.control_rate_hz 200 but pid_controller.control_rate_hz 50: the loop has one",
    ):
        cfg.load_stack("default", path)
    params = cfg.load_stack()
    params["pid_controller"]["control_rate_hz"] = 50.0  # built in code, past the files
    with pytest.raises(ConfigError, match="the loop has one control_rate_hz"):
        consistency.check_stack(params)
