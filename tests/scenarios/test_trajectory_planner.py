"""The planner node (no graph spun): live changes of its shape checked against the joint ranges as at start and
blended from the reference in force; on the sim's clock, its block stepped on its period's grid, a tick early."""

import numpy as np
import pytest

pytestmark = pytest.mark.ros


@pytest.fixture
def planner(ros_domain):
    import rclpy

    from robot_controller.nodes.trajectory_planner import TrajectoryPlanner

    rclpy.init(args=["trajectory_planner", "--ros-args", "-p", "lockstep:=true"], domain_id=ros_domain)
    node = TrajectoryPlanner()
    node.block.start_s = node.block.origin_s = 0.0  # publishing since t = 0 (lockstep: the planner's time is /clock's)
    node.ticks.clock_s = 3.3
    try:
        yield node
    finally:
        node.destroy_node()
        rclpy.shutdown()


def test_a_live_change_leaving_a_joints_range_is_refused_with_the_reason(planner):
    from rclpy.parameter import Parameter

    result = planner.set_parameters_atomically([Parameter("offset", value=[2.5])])  # 1 rad about 2.5: past π
    assert not result.successful
    assert "reaches [1.5, 3.5] rad on joint1, beyond its limits [-3.14159, 3.14159] rad" in result.reason
    assert planner.params["offset"] == [0.0] and planner.block.crossfade is None


def test_a_live_change_blends_from_the_reference_in_force(planner):
    from rclpy.parameter import Parameter

    before = planner.block.reference_at(3.3)
    change = [
        Parameter("amplitude", value=[0.5]),
        Parameter("offset", value=[1.0]),
        Parameter("frequency_hz", value=1.0),
    ]
    assert planner.set_parameters_atomically(change).successful
    blend = planner.block.crossfade
    assert blend is not None and blend.start_s == 3.3
    for got, want in zip(planner.block.reference_at(3.3), before, strict=True):
        assert got == pytest.approx(want)  # no jump: position, velocity and acceleration carry on
    t = np.arange(3.3, 3.3 + blend.duration_s + 0.5, 1e-3)
    p, v, _ = np.array([planner.block.reference_at(s) for s in t])[:, :, 0].T
    assert np.max(np.abs(np.diff(p) - (v[1:] + v[:-1]) / 2 * 1e-3)) < 1e-5  # each step as the velocity says: no jump
    assert p[-1] == pytest.approx(1.0 + 0.5 * np.sin(2 * np.pi * t[-1]))  # on the new sine after the blend
    assert planner.block.crossfade is None


def test_on_the_sims_clock_each_grid_points_sample_goes_out_a_tick_early(ros_domain):
    import rclpy
    from rclpy.time import Time
    from rosgraph_msgs.msg import Clock

    from robot_controller.nodes.trajectory_planner import TrajectoryPlanner

    args = ["trajectory_planner", "--ros-args", "-p", "lockstep:=true", "-p", "publish_rate_hz:=20.0"]
    rclpy.init(args=args, domain_id=ros_domain)
    try:
        node = TrajectoryPlanner()
        try:
            sent = []  # (the sim's clock when it went out, its sample time)
            gate = node.publishers_by_port["reference"][0]
            gate.open = True  # its consumers matched
            gate.publish = lambda msg: sent.append((node.ticks.clock_s, msg.data[-1]))
            node.ticks.on_grid(node.ticks.clock_s)  # the start poll, before the sim's first clock: time 0
            for k in range(1, 12):  # the sim ticks at 100 Hz
                node.ticks.clock_callback(Clock(clock=Time(nanoseconds=k * 10_000_000).to_msg()))
            assert np.array(sent) == pytest.approx(np.array([[0.0, 0.0], [0.04, 0.05], [0.09, 0.1]]))
            assert node.block.start_s == 0.0
        finally:
            node.destroy_node()
    finally:
        rclpy.shutdown()
