"""Joint trajectories over the real graph: ``robot-controller goto`` and
``robot-controller trajectory`` send a ``control_msgs/FollowJointTrajectory``
goal from a process of their own and say its result: the planner refuses a
bad one with its reason (exit 2) and carries on, blends a good one from the
reference in force and holds its last point, the arm gets there (exit 0), and
Ctrl-C cancels a goal: the arm stops and holds (exit 130). With no server the
goal is not sent (exit 1). Real nodes, real DDS, its own ROS_DOMAIN_ID."""

import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from robot_controller.scoring import report
from tests import rostools
from tests.rostools import run_said

pytestmark = pytest.mark.ros

TOPIC = "/trajectory_planner/joint_trajectory"
TARGET_RAD, MOVE_S = 0.5, 1.5
# A long move, so that the Ctrl-C comes while it runs however busy the host (it is canceled within a second or so).
CANCELED_TARGET_RAD, CANCELED_MOVE_S = -0.3, 30.0
TAKEN = "joint trajectory taken"


def cli(*args):
    return subprocess.run(
        [sys.executable, "-m", "robot_controller.cli", *args], capture_output=True, text=True, timeout=60
    )


def test_goals_are_refused_blended_tracked_held_and_canceled(tmp_path, ros_domain):
    bad = tmp_path / "bad.yaml"
    bad.write_text("joint_names: [joint1]\npoints: [{time_from_start: 1.0, positions: [4.0]}]\n")
    out = tmp_path / "run"
    run = rostools.start_run(out, "300")  # interrupted once the tools are done, however long they took
    said: list[str] = []
    threading.Thread(target=lambda: said.extend(run.stdout), daemon=True).start()  # its pipe must not fill up
    try:
        refused = cli("trajectory", str(bad))
        sent = cli("goto", f"{TARGET_RAD}", "--time", f"{MOVE_S}")
        # A long move, interrupted once the planner has taken it.
        moving = subprocess.Popen(
            [sys.executable, "-m", "robot_controller.cli", "goto", f"{CANCELED_TARGET_RAD}"]
            + ["--time", f"{CANCELED_MOVE_S}"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            # Started as a shell's `&` starts it (SIGINT ignored, which Python then keeps): a SIGINT still cancels.
            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN),
        )
        try:
            rostools.wait_for(lambda: sum(TAKEN in line for line in said) == 2, 60, "the planner to take the move")
            moving.send_signal(signal.SIGINT)
            canceled_out, canceled_err = moving.communicate(timeout=60)
        finally:
            if moving.poll() is None:
                moving.kill()
        time.sleep(0.5)  # a recorded hold after the stop
        run.send_signal(signal.SIGINT)
        run.wait(timeout=120)
    finally:
        if run.poll() is None:
            run.kill()
    output = "".join(said)
    assert refused.returncode == 2, refused.stdout + refused.stderr
    assert refused.stdout == ""
    assert refused.stderr == (
        "robot-controller trajectory: 1 point(s) over 1 s: REJECTED by /joint_trajectory_controller/"
        "follow_joint_trajectory: points[0]: joint1 position 4 rad is above its upper limit 3.14159 rad\n"
    )
    assert sent.returncode == 0, sent.stdout + sent.stderr
    assert sent.stdout.startswith(
        f"robot-controller goto: joint1 {TARGET_RAD:g} rad in {MOVE_S:g} s: SUCCEEDED (reached within its goal "
        "tolerance "
    ), sent.stdout
    assert sent.stdout.endswith(" s after its end)\n") and sent.stderr == ""
    assert moving.returncode == 130, canceled_out + canceled_err
    assert canceled_err == (
        f"robot-controller goto: joint1 {CANCELED_TARGET_RAD:g} rad in {CANCELED_MOVE_S:g} s: interrupted: "
        "cancel accepted; CANCELED (the arm stopped and holds where it came to rest)\n"
    )
    assert run.returncode == 0, run_said(output)
    assert "[trajectory_planner] [WARN]" in output and "goal rejected: points[0]: joint1 position 4 rad" in output
    assert output.count(TAKEN) == 2
    assert "succeeded: reached within its goal tolerance" in output and "canceled: the arm stopped" in output

    recording = report.read_recording(out / "bag")
    assert recording.counts.get(TOPIC, 0) == 0  # goals, not the topic
    t, q, v = recording.planned_time_s, recording.planned_position[:, 0], recording.planned_velocity[:, 0]
    # The goto's hold: exactly the target, at rest, until the canceled move began.
    at_target = (q == TARGET_RAD) & (v == 0.0)
    assert at_target.any()
    first = int(np.argmax(at_target))
    last = first + int(np.argmin(at_target[first:])) - 1
    held_from_s, held_to_s = t[first], t[last]
    assert last - first > 100 and np.all(at_target[first : last + 1]), (held_from_s, held_to_s)
    # Before: the sine went on through the refusal. Around the goto's join (MOVE_S before its hold, plus a stop
    # first if joining directly would swing past its point): no jump in the reference, each step what its own
    # velocity says.
    around = (t > held_from_s - MOVE_S - 1.0) & (t < held_from_s)
    steps, spans = np.diff(q[around]), np.diff(t[around])
    mean_velocity = 0.5 * (v[around][1:] + v[around][:-1])
    assert np.max(np.abs(steps - mean_velocity * spans)) < 0.005
    # And the arm is there.
    settled = (recording.true_time_s > held_from_s + 1.0) & (recording.true_time_s < held_to_s)
    assert settled.sum() > 50
    assert np.max(np.abs(recording.true_position[settled, 0] - TARGET_RAD)) < 0.02
    # The canceled move stopped on its way and holds there.
    after = t > held_to_s
    assert v[after][-1] == 0.0 and q[after][-1] == q[after][-2]
    assert CANCELED_TARGET_RAD < q[after][-1] < TARGET_RAD


def test_with_no_server_the_goal_is_not_sent(ros_domain):
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            "import sys\nfrom robot_controller.tools import send_trajectory as s\n"
            "sys.exit(s.goto([0.5], 1.0, ['joint1'], controller='arm_controller', wait_s=1.0))",
        ],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 1 and done.stdout == ""
    assert done.stderr == (
        f"robot-controller goto: joint1 0.5 rad in 1 s: no /arm_controller/follow_joint_trajectory action server on "
        f"domain {ros_domain} within 1 s, the goal was not sent (is the planner running, its controller_name "
        "arm_controller?)\n"
    )


def test_the_planner_node_blends_takes_a_stamp_and_gives_way_to_a_shape_change(ros_domain):
    import rclpy
    from rclpy.parameter import Parameter
    from rclpy.time import Time
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    from robot_controller.nodes.trajectory_planner import TrajectoryPlanner
    from robot_controller.ros.messages import clock_s, decode

    rclpy.init(args=[], domain_id=ros_domain)
    try:
        node = TrajectoryPlanner()
        try:
            now = clock_s(node)
            node.block.start_s = node.block.origin_s = now - 0.3  # publishing the sine for 0.3 s
            before = node.block.reference_at(now)
            msg = JointTrajectory(joint_names=["joint1"])
            msg.points.append(JointTrajectoryPoint(positions=[0.4]))
            msg.points[0].time_from_start.sec = 2
            msg.header.stamp = Time(nanoseconds=round((now + 1.0) * 1e9)).to_msg()  # in the future: its time 0 is then
            node.ticks.take("waypoints", decode(msg))
            assert node.block.waypoints is not None
            assert node.block.waypoints.start_delay_s == pytest.approx(1.0, abs=0.1)
            # From the sine's state at receipt (the sine moved on for the microseconds in between).
            for got, want in zip(node.block.reference_at(node.block.origin_s), before, strict=True):
                np.testing.assert_allclose(got, want, atol=0.01)
            assert node.block.reference_at(node.block.origin_s + 10.0)[0].tolist() == [0.4]
            msg.joint_names = ["joint1", "joint1"]
            node.ticks.take("waypoints", decode(msg))  # refused: the one in force stays
            assert node.block.reference_at(node.block.origin_s + 10.0)[0].tolist() == [0.4]
            assert node.set_parameters_atomically([Parameter("mode", value="hold")]).successful
            assert node.block.waypoints is None and node.block.origin_s == node.block.start_s
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown()
