"""Joint trajectories over the real graph: ``robot-controller goto`` and
``robot-controller trajectory`` send a ``trajectory_msgs/JointTrajectory``
from a process of their own (the observer profile, into the run's
partition); the planner refuses a bad one with its reason and carries on,
blends a good one from the reference in force and holds its last point, and
the arm gets there. Real nodes, real DDS, its own ROS_DOMAIN_ID."""

import subprocess
import sys

import numpy as np
import pytest

from robot_controller.scoring import report
from tests import rostools
from tests.rostools import run_said

pytestmark = pytest.mark.ros

TOPIC = "/trajectory_planner/joint_trajectory"
TARGET_RAD, MOVE_S = 0.5, 1.5


def cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", *args], capture_output=True, text=True, timeout=60
    )


def test_goto_is_blended_tracked_and_held_and_a_bad_trajectory_is_refused(tmp_path, ros_domain):
    bad = tmp_path / "bad.yaml"
    bad.write_text("joint_names: [elbow]\npoints: [{time_from_start: 1.0, positions: [0.2]}]\n")
    out = tmp_path / "run"
    run = rostools.start_run(out, "14")  # the two tools find the planner within seconds, more on a busy host
    try:
        refused = cli("trajectory", str(bad))
        sent = cli("goto", f"{TARGET_RAD}", "--time", f"{MOVE_S}")
        output = run.communicate(timeout=60)[0]
    finally:
        if run.poll() is None:
            run.kill()
    assert refused.returncode == 2, refused.stdout + refused.stderr
    assert refused.stderr.strip() == (
        "robot-controller trajectory: the planner refused it: unknown joint(s) ['elbow']: "
        "the arm's joints are ['joint1']; the motion goes on as it was"
    )
    assert sent.returncode == 0, sent.stdout + sent.stderr
    assert f"sent joint1 {TARGET_RAD:g} rad in {MOVE_S:g} s on {TOPIC}" in sent.stdout
    assert "the planner took it: 1 point(s), reaching [0.5] rad 1.5 s from now" in sent.stdout
    assert run.returncode == 0, run_said(output)
    assert "[trajectory_planner] [WARN]" in output and "joint trajectory refused: unknown joint(s)" in output
    assert output.count("joint trajectory taken") == 1

    recording = report.read_recording(out / "bag")
    assert recording.counts[TOPIC] == 2  # both recorded
    taken_s = recording.receipt_s[TOPIC][-1]
    t, q, v = recording.planned_time_s, recording.planned_position[:, 0], recording.planned_velocity[:, 0]
    # Before: the sine went on through the refusal. Around the goto: no jump in the reference, each
    # step what its own velocity says (the blend may outrun the sine's π rad/s: taken at the sine's
    # peak speed away from the goal, it carried on to 1.12 rad, 38 mrad a sample, before turning back).
    around = (t > taken_s - 0.5) & (t < taken_s + 0.5)
    steps, spans = np.diff(q[around]), np.diff(t[around])
    mean_velocity = 0.5 * (v[around][1:] + v[around][:-1])
    assert np.max(np.abs(steps - mean_velocity * spans)) < 0.005
    # After: exactly the target, at rest, held to the end.
    held = t > taken_s + MOVE_S + 0.05
    assert held.sum() > 100, held.sum()
    assert np.all(q[held] == TARGET_RAD) and np.all(v[held] == 0.0)
    # And the arm is there.
    settled = recording.true_time_s > taken_s + MOVE_S + 1.0
    assert settled.sum() > 50
    assert np.max(np.abs(recording.true_position[settled, 0] - TARGET_RAD)) < 0.02


def test_the_planner_node_blends_takes_a_stamp_and_gives_way_to_a_shape_change(ros_domain):
    import rclpy
    from rclpy.parameter import Parameter
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    from robot_controller.nodes.trajectory_planner import TrajectoryPlanner
    from robot_controller.ros.messages import clock_s, s_to_stamp

    rclpy.init(args=[], domain_id=ros_domain)
    try:
        node = TrajectoryPlanner()
        try:
            now = clock_s(node)
            node.start_s = node.origin_s = now - 0.3  # publishing the sine for 0.3 s
            before = node.reference_at(now)
            msg = JointTrajectory(joint_names=["joint1"])
            msg.points.append(JointTrajectoryPoint(positions=[0.4]))
            msg.points[0].time_from_start.sec = 2
            msg.header.stamp = s_to_stamp(now + 1.0)  # in the future: its time 0 is then
            node.joint_trajectory_callback(msg)
            assert node.waypoints is not None
            assert node.waypoints.start_delay_s == pytest.approx(1.0, abs=0.1)
            # From the sine's state at receipt (the sine moved on for the microseconds in between).
            for got, want in zip(node.reference_at(node.origin_s), before, strict=True):
                np.testing.assert_allclose(got, want, atol=0.01)
            assert node.reference_at(node.origin_s + 10.0)[0].tolist() == [0.4]
            msg.joint_names = ["joint1", "joint1"]
            node.joint_trajectory_callback(msg)  # refused: the one in force stays
            assert node.reference_at(node.origin_s + 10.0)[0].tolist() == [0.4]
            assert node.set_parameters_atomically([Parameter("mode", value="hold")]).successful
            assert node.waypoints is None and node.origin_s == node.start_s
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown()
