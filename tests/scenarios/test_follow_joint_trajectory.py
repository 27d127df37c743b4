"""The arm as a plain ROS client sees it: FollowJointTrajectory on ``/joint_trajectory_controller/
follow_joint_trajectory``, ``/joint_states`` and ``/robot_description``, from a process that knows nothing of the
run's DDS profile or partition (tests/scenarios/follow_joint_trajectory_client.py, started without
FASTRTPS_DEFAULT_PROFILES_FILE on the run's ROS_DOMAIN_ID). A goal succeeds with feedback, a new goal preempts the
one in force, a cancel stops and holds, an unknown joint is rejected and an impossible path tolerance ends with JTC's
error code; the run's own recording says where the reference and the arm were meanwhile. Goals are judged as JTC judges
them: an invalid one rejected at once, a cancel at speed at rest within 0.5 s, a frozen controller's goal aborted.
Real nodes, real DDS."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from robot_controller.ros import partition
from robot_controller.scoring import report
from tests.rostools import child_pid, run_said

pytestmark = pytest.mark.ros

CLIENT = Path(__file__).with_name("follow_joint_trajectory_client.py")
# What a client that never heard of us has: none of our DDS settings.
OURS = (partition.PROFILES_ENV, "FASTDDS_DEFAULT_PROFILES_FILE", partition.PARTITION_ENV, partition.LOOP_QOS_ENV)
INVALID_GOAL, PATH_TOLERANCE_VIOLATED = -1, -4  # control_msgs' result codes


def run_with_client(out: Path, robot: str, duration: str, *client_args: str, freeze: bool = False) -> tuple[dict, str]:
    """A run of ``robot`` into ``out`` and, once its loop runs, the plain client beside it: what the client printed
    (its JSON) and what the run said. The run must end by itself, with exit 0 unless ``freeze``: the client is given
    the controller's pid to freeze (a run whose arm was braked by a frozen controller is not judged here)."""
    command = ["run", "--robot", robot, "--duration", duration, "--out", str(out)]
    run = subprocess.Popen(
        [sys.executable, "-m", "robot_controller.cli", *command],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    before = []  # what the run said before its loop ran (rostools.start_run's wait, keeping the lines)
    for line in run.stdout:
        before.append(line)
        if "control loop running" in line:
            break
    else:
        run.wait(timeout=60)
        pytest.fail(f"the run ended (exit {run.returncode}) before its loop ran:\n{run_said(''.join(before))}")
    try:
        env = {name: value for name, value in os.environ.items() if name not in OURS}
        if freeze:
            client_args = (*client_args, "--freeze-pid", str(child_pid(run, "pid_controller")))
        client = subprocess.run(
            [sys.executable, str(CLIENT), *client_args], capture_output=True, text=True, timeout=180, env=env
        )
        output = "".join(before) + run.communicate(timeout=240)[0]
    finally:
        if run.poll() is None:
            run.kill()
    said = f"client exit {client.returncode}\n{client.stdout[-3000:]}\n{client.stderr[-3000:]}"
    (out / "client.json").write_text(client.stdout)  # beside the run's bag, for a failure's reader
    (out / "run.log").write_text(output)
    assert client.returncode == 0 and client.stdout.strip(), said
    assert freeze or run.returncode == 0, run_said(output) + "\n" + said
    return json.loads(client.stdout.strip().splitlines()[-1]), output


def check_public_face_and_success(got: dict, joints: list[str]) -> None:
    """The client found the action, heard the arm and its description, and a 3-point goal succeeded with feedback."""
    assert got["server"], got
    assert (got["joint_states_publishers"], got["action_servers"]) == (1, 1), f"not one arm on the domain: {got}"
    assert got["joint_states_heard"] >= 20 and got["joint_names"] == joints, got
    assert got["robot_description_chars"] > 0 and got["description_names_every_joint"], got  # the arm's URDF
    three = got["three_point"]
    assert (three["status"], three["error_code"]) == ("SUCCEEDED", 0), three
    feedback = three["feedback"]
    assert feedback["count"] > 10 and feedback["joint_names"] == [joints], feedback
    assert feedback["max_error_rad"] < 0.02, feedback  # the controller's estimate follows the goal's reference
    # Its last feedback was on the last point (base + 0.15), and the arm was left there.
    np.testing.assert_allclose(feedback["desired_last"], np.add(got["base"], 0.15), atol=0.02)
    np.testing.assert_allclose(got["after_three_point"], np.add(got["base"], 0.15), atol=0.02)


def check_the_other_goals(got: dict, out: Path, joints: list[str]) -> None:
    """Preemption, cancel then hold (the client's readings and the run's recording), and two refusals."""
    assert (got["preempted"]["status"], got["preempted"]["error_code"]) == ("ABORTED", INVALID_GOAL), got
    assert got["preempted"]["error_string"] == "preempted by a new goal"
    assert (got["preempting"]["status"], got["preempting"]["error_code"]) == ("SUCCEEDED", 0), got
    assert got["cancel_accepted"], got
    assert got["canceled"]["status"] == "CANCELED", got
    hold = got["hold"]
    assert hold["samples"] >= 20 and hold["drift_rad"] < 0.015, hold  # noisy readings (σ 5 mrad), averaged

    assert got["unknown_joint"]["status"] == "REJECTED", got["unknown_joint"]  # in the goal callback, as JTC does
    tight = got["tight_path_tolerance"]
    assert (tight["status"], tight["error_code"]) == ("ABORTED", PATH_TOLERANCE_VIOLATED), tight
    assert "is outside its path tolerance ±1e-06 rad" in tight["error_string"]

    # The recording, on the run's clock (the client's times are /joint_states stamps: one published after it had the
    # result, and the latest it heard while it watched the hold): from the cancel's result until the client stopped
    # watching, the reference stood still where the stop brought it, between where the cancelled move started
    # (base + 0.1) and its target (base + 0.5): it stopped, not swung past. The arm held it.
    recording = report.read_recording(out / "bag")
    assert recording.joint_names == joints
    start_s, until_s = got["canceled"]["stamp_s"] + 0.1, hold["until_stamp_s"]
    t, q = recording.planned_time_s, recording.planned_position
    window = (t > start_s) & (t < until_s)
    assert window.sum() > 50, (start_s, until_s)
    held = q[window][0]
    assert np.all(q[window] == held), f"the reference moved in {start_s:.2f}-{until_s:.2f} s: see {out}"
    base = np.asarray(got["base"])
    assert np.all(held >= base + 0.1 - 1e-6) and np.all(held <= base + 0.5 + 1e-6), (held - base).tolist()
    settled = (recording.true_time_s > hold["from_stamp_s"]) & (recording.true_time_s < until_s)
    assert settled.sum() > 50
    assert np.max(np.abs(recording.true_position[settled] - held)) < 0.01


def test_a_plain_ros_client_drives_the_arm_through_follow_joint_trajectory(tmp_path, ros_domain):
    out = tmp_path / "run"
    got, output = run_with_client(out, "one_dof", "35")
    joints = ["joint1"]
    check_public_face_and_success(got, joints)
    check_the_other_goals(got, out, joints)
    assert output.count("canceled: the arm stopped and holds where it came to rest") == 1


@pytest.mark.slow
def test_the_panda_follows_a_goal_on_all_seven_joints_for_a_plain_client(tmp_path, ros_domain):
    out = tmp_path / "panda"
    got, _ = run_with_client(out, "panda", "40")
    joints = [f"panda_joint{k}" for k in range(1, 8)]
    check_public_face_and_success(got, joints)
    check_the_other_goals(got, out, joints)


#: At rest, as judged from the recorded true state: within this much of where it holds, for two seconds (the sensor's
#: 5 mrad noise keeps a held arm wandering by 1-3 mrad, single readings' velocity up to 0.06 rad/s; a drift of
#: 5 mrad/s would take it 10 mrad away).
REST_SPREAD_RAD = 0.004
CANCEL_TO_REST_S = 0.5  #: how soon after a cancel at the sine's speed the arm is at rest


def test_goals_are_judged_as_jtc_judges_them(tmp_path, ros_domain):
    """An unknown joint is rejected at goal time; a swing cancelled at the sine's speed is at rest within 0.5 s and
    holds (the recorded true state); a goal under a controller frozen from mid-motion until past the goal's end is
    aborted with the reason, never reported reached."""
    out = tmp_path / "run"
    got, output = run_with_client(out, "one_dof", "25", "--judge", freeze=True)
    assert got["unknown_joint"]["status"] == "REJECTED", got["unknown_joint"]
    assert "[WARN] goal rejected: unknown joint(s) ['no_such_joint']: the arm's joints are ['joint1']" in output
    assert got["to_home"]["status"] == "SUCCEEDED", got["to_home"]

    assert got["cancel_accepted"] and got["canceled"]["status"] == "CANCELED", got
    recording = report.read_recording(out / "bag")
    cancel_s, until_s = got["cancel_stamp_s"], got["hold_until_stamp_s"]
    t, q, v = recording.true_time_s, recording.true_position, recording.true_velocity
    moving = (t > cancel_s - 0.05) & (t < cancel_s)
    assert np.max(np.abs(v[moving])) > 2.5, "the arm was not at the sine's speed when the cancel went"
    # The reference: at rest and still from 0.5 s after the cancel (the stop at 20 rad/s² from 3.2 rad/s takes 0.3 s).
    pt, pq, pv = recording.planned_time_s, recording.planned_position, recording.planned_velocity
    still = (pt > cancel_s + CANCEL_TO_REST_S) & (pt < until_s)
    assert still.sum() > 100 and np.all(pv[still] == 0.0) and np.all(pq[still] == pq[still][0]), f"see {out}"
    # The arm: there too, and it holds.
    rest = (t > cancel_s + CANCEL_TO_REST_S) & (t < until_s)
    assert rest.sum() > 100, (cancel_s, until_s)
    held = np.median(q[rest], axis=0)
    spread = np.max(np.abs(q[rest] - held))
    said = f"from 0.5 s after the cancel to {until_s - cancel_s:.2f} s: up to {spread * 1000:.2f} mrad off {held} rad"
    assert spread < REST_SPREAD_RAD, said
    assert np.max(np.abs(held - pq[still][0])) < REST_SPREAD_RAD, said
    assert np.all(np.abs(q[(t > cancel_s) & (t < until_s)]) < np.pi)  # one_dof_arm.urdf's range: ±3.14159 rad

    frozen = got["frozen"]
    assert frozen["status"] == "ABORTED" and frozen["error_code"] == PATH_TOLERANCE_VIOLATED, frozen
    reason = frozen["error_string"]
    assert "the arm's brakes engaged" in reason or "(/controller/state) is stale" in reason, reason
    assert f"aborted: {reason}" in output
