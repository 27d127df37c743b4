"""A split run's clock check on the launcher's side, fed the recording launcher's ``@clock`` lines (no ROS)."""

import json

from robot_controller.nodes import graph_watch
from robot_controller.runner import supervise


def clock_line(offset_ms, apart=None):
    fields = {"peer": "h2: trajectory_planner", "offset_ms": offset_ms, "round_trip_ms": 0.8, "apart": apart}
    return graph_watch.CLOCK_PREFIX + json.dumps(fields)


def test_the_graph_link_keeps_the_latest_clock_and_says_a_drift_past_the_limit_once(capsys):
    graph = supervise.GraphLink()
    assert not graph.on_line("hello") and graph.clock is None
    assert graph.on_line(clock_line(4.0))
    assert graph.clock["offset_ms"] == 4.0
    for _ in range(2):
        assert graph.on_line(clock_line(50.0, apart="the clock of the other launcher is +50.0 ms from this one's"))
    graph.on_line(clock_line(1.0))
    out = capsys.readouterr().out
    assert out.count("WARNING: the clocks drifted apart: the clock of the other launcher is +50.0 ms") == 1
    assert graph.clock["offset_ms"] == 1.0 and graph.clock["apart"] is None
