"""User mistakes at the command line: one line on stderr, exit code 2, no
traceback, nothing overwritten. No ROS is started: each is refused first."""

import subprocess
import sys

import pytest

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError
from robot_controller.parameters import consistency as config_check


def cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", *args], capture_output=True, text=True, timeout=60
    )


def one_line_error(proc, expected):
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and expected in lines[0], proc.stderr


def test_an_out_dir_holding_a_run_is_refused_and_left_as_it_was(tmp_path):
    out = tmp_path / "earlier"
    out.mkdir()
    (out / "params.yaml").write_text("mine\n")
    (out / "metrics.json").write_text("{}\n")
    one_line_error(cli("run", "--duration", "1", "--out", str(out)), "holds an earlier run")
    assert (out / "params.yaml").read_text() == "mine\n" and sorted(p.name for p in out.iterdir()) == [
        "metrics.json",
        "params.yaml",
    ]


@pytest.mark.parametrize(
    "args, expected",
    [
        (["run", "--duration", "nan"], "must be a finite number > 0"),
        (["run", "--duration", "-1"], "must be a finite number > 0"),
        (["run", "--duration", "soon"], "not a number"),
        (["score", "/nonexistent/run"], "cannot score"),
        (["run", "--config", "/nonexistent/params.yaml"], "/nonexistent/params.yaml"),
        (["run", "--preset", "fastest"], "invalid choice"),
        (["run", "--sim"], "robot-controller run: unrecognized arguments: --sim"),  # no abbreviations
        (["step", "--amplitude", "0", "--sim-time"], "must be a finite number other than 0"),
    ],
)
def test_user_errors_are_one_line(args, expected):
    one_line_error(cli(*args), expected)


def test_an_out_that_is_a_file_is_refused(tmp_path):
    out = tmp_path / "file"
    out.write_text("x")
    one_line_error(cli("run", "--duration", "1", "--out", str(out)), "exists and is not a directory")


@pytest.mark.parametrize(
    "node, key, value, expected",
    [
        ("pid_controller", "control_rate_hz", 1000.0, "watchdog_periods 5 at control_rate_hz 1000"),
        ("motor_node", "torque_max", [1e6], "exceeds the URDF's effort limit"),
        ("trajectory_planner", "amplitude", [100.0], "beyond its limits"),
        ("trajectory_planner", "joint_count", 2, "joint_count 2 but the URDF has 1"),
        ("pid_controller", "lqr_q", [0.0, 0.0, 0.0], "does not stabilise"),
        ("simulator", "publish_rate_hz", 300.0, "not a whole number of physics steps"),
        ("simulator", "urdf_path", "/nonexistent.urdf", "no such file"),
        ("sensor_node", "rate_hz", 500.0, "faster than the simulator publishes"),
    ],
)
def test_the_whole_configuration_is_checked_before_anything_starts(node, key, value, expected):
    params = cfg.load_stack()
    params[node][key] = value
    with pytest.raises(ConfigError, match=expected):
        config_check.check_stack(params)


def test_presets_pass_the_whole_configuration_check():
    for preset in cfg.available_presets():
        config_check.check_stack(cfg.load_stack(preset))


def test_a_config_file_that_breaks_the_loop_is_refused_at_the_cli(tmp_path):
    path = tmp_path / "fast.yaml"
    path.write_text("pid_controller:\n  ros__parameters:\n    control_rate_hz: 1000\n")
    one_line_error(
        cli("run", "--duration", "1", "--config", str(path), "--out", str(tmp_path / "run")),
        "raise watchdog_periods to at least 20",
    )
    assert not (tmp_path / "run").exists()
