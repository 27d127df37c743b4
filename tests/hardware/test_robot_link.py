"""The memory a robot's drive and its ROS side share: whole samples one way, every tick's record the other, and
never a wait."""

import numpy as np

from robot_controller.hardware.robot_link import END, ESTOP, GO, RING_TICKS, RobotLink


def _record(link: RobotLink, k: int) -> None:
    n = link.joint_count
    link.record(float(k), 1e-4, 1.0, 0, np.full(n, k), np.zeros(n), np.zeros(n), np.full(link.state_size, -k))


def test_a_sample_is_taken_once_and_whole():
    link = RobotLink(2, 5)
    assert link.new_reference() is None
    link.offer_reference(1.5, np.arange(6.0))
    time_s, sample = link.new_reference()
    assert time_s == 1.5 and sample.tolist() == list(range(6))
    assert link.new_reference() is None, "taken once"
    link.offer_reference(1.6, np.ones(6))
    link.offer_reference(1.7, 2 * np.ones(6))
    assert link.new_reference()[0] == 1.7, "the newest, the one before it passed over"


def test_every_tick_is_read_in_order_and_a_slow_reader_is_told_what_it_lost():
    link = RobotLink(3, 4)
    for k in range(5):
        _record(link, k)
    rows, lost = link.rows()
    assert lost == 0 and [row.time_s for row in rows] == [0, 1, 2, 3, 4]
    assert rows[2].position.tolist() == [2, 2, 2] and rows[2].state.tolist() == [-2] * 4
    assert link.rows() == ([], 0)
    for k in range(RING_TICKS + 10):  # the reader held up longer than the record holds: the oldest are gone
        _record(link, 100 + k)
    rows, lost = link.rows()
    assert lost == 10 and len(rows) == RING_TICKS and rows[0].time_s == 110


def test_requests_and_the_drive_s_phase_pass_both_ways():
    link = RobotLink(1, 1)
    assert not any(link.requested(flag) for flag in (ESTOP, END, GO))
    link.request(ESTOP)
    assert link.requested(ESTOP) and not link.requested(END)
    assert link.phase() == "starting"
    link.say_phase("estopped")
    assert link.phase() == "estopped"
