"""The ``trajectory`` verb's YAML file and ``goto``'s request, without a graph:
what is sent, a bad file named by key and problem in one line, and how a
goal's result is said and exits."""

import subprocess
import sys

import pytest

from robot_controller.tools import trajectory_file
from robot_controller.tools.send_trajectory import action_name, to_message, verdict
from robot_controller.tools.trajectory_file import TrajectoryFileError

GOOD = """\
joint_names: [joint1, joint2]
points:
  - time_from_start: 1.0
    positions: [0.5, -0.25]
    velocities: [0.1, 0.0]
  - time_from_start: 2.5
    positions: [0, 1]
    velocities: [0, 0]
"""


def test_a_file_becomes_one_joint_trajectory_message(tmp_path):
    path = tmp_path / "t.yaml"
    path.write_text(GOOD)
    spec = trajectory_file.load(path)
    assert spec.duration_s == 2.5
    msg = to_message(spec)
    assert list(msg.joint_names) == ["joint1", "joint2"]
    assert msg.header.stamp.sec == 0 and msg.header.stamp.nanosec == 0  # timed from receipt
    assert [p.time_from_start.sec for p in msg.points] == [1, 2]
    assert msg.points[1].time_from_start.nanosec == 500_000_000
    assert list(msg.points[0].positions) == [0.5, -0.25] and list(msg.points[0].velocities) == [0.1, 0.0]
    assert list(msg.points[0].accelerations) == []


def test_the_goal_goes_to_the_controllers_action():
    assert action_name("joint_trajectory_controller") == "/joint_trajectory_controller/follow_joint_trajectory"
    assert action_name("arm_controller") == "/arm_controller/follow_joint_trajectory"


@pytest.mark.parametrize(
    ("status", "code", "reason", "said", "exit_code"),
    [
        (4, 0, "reached within its goal tolerance 0.01 s after its end", "SUCCEEDED (reached within", 0),
        (6, -1, "points[0]: joint1 position 4 rad is above", "ABORTED, INVALID_GOAL (-1): points[0]: joint1", 2),
        (6, -2, "unknown joint(s) ['elbow']", "ABORTED, INVALID_JOINTS (-2): unknown joint(s)", 2),
        (6, -3, "header.stamp", "ABORTED, OLD_HEADER_TIMESTAMP (-3): header.stamp", 2),
        (6, -4, "joint1 position error", "ABORTED, PATH_TOLERANCE_VIOLATED (-4): joint1", 2),
        (6, -5, "joint1 position error", "ABORTED, GOAL_TOLERANCE_VIOLATED (-5): joint1", 2),
        (6, -9, "", "ABORTED, error code (-9): no reason given", 2),
        (5, 0, "the arm stopped and holds", "CANCELED (the arm stopped and holds)", 2),
        (4, -4, "inconsistent", "ended with status 4, PATH_TOLERANCE_VIOLATED (-4): inconsistent", 1),
        (0, 0, "", "ended with status 0", 1),
    ],
)
def test_a_result_is_said_with_its_code_name_and_reason(status, code, reason, said, exit_code):
    """GoalStatus: 4 succeeded, 5 canceled, 6 aborted; control_msgs' error codes by name."""
    words, got = verdict(status, code, reason)
    assert words.startswith(said), words
    assert got == exit_code


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("- 1\n", "expected a mapping with joint_names and points"),
        ("joint_name: [a]\npoints: []\n", "'joint_name': unknown key (did you mean 'joint_names'?)"),
        ("joint_names: [a]\n", "points: missing"),
        ("joint_names: a\npoints: [{time_from_start: 1, positions: [1]}]\n", "joint_names: expected a list"),
        ("joint_names: [a]\npoints: []\n", "points: expected a list of at least one point"),
        ("joint_names: [a]\npoints: [{positions: [1]}]\n", "points[0].time_from_start: missing"),
        ("joint_names: [a]\npoints: [{time_from_start: -1, positions: [1]}]\n", "expected a finite number of seconds"),
        (
            "joint_names: [a]\npoints: [{time_from_start: 1, positions: [1]}, {time_from_start: 1, positions: [2]}]\n",
            "points[1].time_from_start: 1 s is not after points[0]'s 1 s",
        ),
        (
            "joint_names: [a, b]\npoints: [{time_from_start: 1, positions: [1]}]\n",
            "points[0].positions: expected 2 number(s) (one per joint name), got 1",
        ),
        ("joint_names: [a]\npoints: [{time_from_start: 1, positions: [x]}]\n", "points[0].positions[0]: expected a"),
        ("joint_names: [a]\npoints: [{time_from_start: 1, position: [1]}]\n", "'position': unknown key (did you"),
        (
            "joint_names: [a]\npoints: [{time_from_start: 1, positions: [1], velocities: [0]},"
            " {time_from_start: 2, positions: [1]}]\n",
            "points[1].velocities: missing (give velocities for every point or none)",
        ),
        ("joint_names: [a\n", "not YAML (line 2, column 1)"),
    ],
)
def test_a_bad_file_is_one_line_naming_the_key(tmp_path, text, expected):
    path = tmp_path / "t.yaml"
    path.write_text(text)
    with pytest.raises(TrajectoryFileError) as raised:
        trajectory_file.load(path)
    message = str(raised.value)
    assert message.startswith(f"{path}: ") and expected in message, message
    assert "\n" not in message


def test_goto_is_one_point_at_rest_and_its_default_time_is_safe():
    spec = trajectory_file.goto([0.5, -1.0], ["joint1", "joint2"], 2.0)
    assert spec.points[0].positions == [0.5, -1.0] and spec.points[0].velocities == []
    with pytest.raises(TrajectoryFileError, match=r"1 position\(s\) for 2 joint\(s\)"):
        trajectory_file.goto([0.5], ["joint1", "joint2"], 2.0)
    assert trajectory_file.goto_time_s(0.1, 0.0) == trajectory_file.GOTO_MIN_S
    assert trajectory_file.goto_time_s(2.0, 0.0) == pytest.approx(4.0)  # 0.5 rad/s on average
    assert trajectory_file.goto_time_s(0.1, 6.0) == pytest.approx(3.0)  # brought to rest first


def test_the_cli_refuses_a_bad_file_before_touching_the_graph(tmp_path):
    path = tmp_path / "t.yaml"
    path.write_text("joint_names: [a]\npoints: [{time_from_start: 1, positions: [1, 2]}]\n")
    proc = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", "trajectory", str(path)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 2
    assert proc.stderr == (
        f"robot-controller trajectory: {path}: points[0].positions: expected 1 number(s) (one per joint name), got 2\n"
    )
    missing = subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", "trajectory", str(tmp_path / "none.yaml")],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert missing.returncode == 2 and "Traceback" not in missing.stderr and "none.yaml" in missing.stderr
