"""graph_watch's clock exchange without ROS: an answerer on a clock 200 ms ahead, the asker's ``@clock`` line."""

import itertools
import json

from robot_controller.nodes import graph_watch


class Topic:
    def __init__(self):
        self.sent = []

    def publish(self, msg):
        self.sent.append(msg)


class StubNode:
    def create_publisher(self, msg_type, topic, depth):
        return Topic()

    def create_subscription(self, msg_type, topic, callback, depth):
        return None


def test_an_answerer_200_ms_ahead_is_measured_and_the_line_names_both_clocks(monkeypatch, capsys):
    asker = graph_watch.ClockProbe(StubNode(), 0.015, "robot-host: simulator,motor_node")
    answerer = graph_watch.ClockProbe(StubNode(), None, "control-host: pid_controller")
    ticks = itertools.count(step=400_000)  # each stamp 0.4 ms after the last, on either host
    monkeypatch.setattr(graph_watch.time, "time_ns", lambda: next(ticks))
    ahead = lambda: next(ticks) + 200_000_000  # noqa: E731 - the answerer's clock
    for _ in range(graph_watch.PROBE_MIN_SAMPLES):
        asker.ask()
        monkeypatch.setattr(graph_watch.time, "time_ns", ahead)
        answerer.on_request(asker.out.sent[-1])
        monkeypatch.setattr(graph_watch.time, "time_ns", lambda: next(ticks))
        asker.on_reply(answerer.out.sent[-1])
    asker.report()
    [line] = capsys.readouterr().out.splitlines()
    clock = json.loads(line.removeprefix(graph_watch.CLOCK_PREFIX))
    assert abs(clock["offset_ms"] - 200.0) < 0.5 and clock["round_trip_ms"] < 2.0
    assert clock["peer"] == "control-host: pid_controller"
    assert "+200.0 ms from this one's (robot-host: simulator,motor_node)" in clock["apart"], clock


def test_a_bad_request_is_ignored():
    answerer = graph_watch.ClockProbe(StubNode(), None, "h")
    answerer.on_request(type("Msg", (), {"data": "{not json"})())
    assert answerer.out.sent == []
