"""Two hosts' clock offset from four stamps (NTP's rule), the quicker half's median, and when it is surely too far."""

import pytest

from robot_controller.core import clock_offset
from robot_controller.core.clock_offset import ClockOffset


def exchange(offset, there, back, turnaround=0.0001, t1=100.0):
    """The four stamps of one exchange whose other clock reads ``offset`` more, ``there``/``back`` s on the wire."""
    t2 = t1 + there + offset
    t3 = t2 + turnaround
    return t1, t2, t3, t3 - offset + back


@pytest.mark.parametrize("offset", [0.0, 0.2, -0.03, 0.005])
def test_a_symmetric_link_gives_the_offset_and_the_round_trip(offset):
    found = clock_offset.estimate([exchange(offset, 0.002, 0.002)])
    assert found.offset_s == pytest.approx(offset, abs=1e-9)
    assert found.round_trip_s == pytest.approx(0.004, abs=1e-9)


def test_a_lopsided_link_skews_the_offset_by_half_its_asymmetry_within_half_the_round_trip():
    found = clock_offset.estimate([exchange(0.01, 0.050, 0.002)])
    assert found.offset_s == pytest.approx(0.01 + 0.024, abs=1e-9)
    assert abs(found.offset_s - 0.01) <= found.round_trip_s / 2


def test_the_estimate_takes_the_quicker_half_so_queued_exchanges_do_not_skew_it():
    quick = [exchange(0.005, 0.001, 0.001) for _ in range(6)]
    queued = [exchange(0.005, 0.080, 0.001) for _ in range(5)]
    found = clock_offset.estimate(queued + quick)
    assert found.offset_s == pytest.approx(0.005, abs=1e-9) and found.round_trip_s == pytest.approx(0.0020)


def test_no_exchange_is_no_estimate():
    with pytest.raises(ValueError):
        clock_offset.estimate([])


def test_surely_beyond_allows_for_half_the_round_trip():
    assert ClockOffset(0.2, 0.002).surely_beyond(0.015)
    assert ClockOffset(-0.2, 0.002).surely_beyond(0.015)
    assert not ClockOffset(0.005, 0.002).surely_beyond(0.015)
    # 40 ms measured over a 100 ms round trip: the clocks may agree, the link lopsided.
    assert not ClockOffset(0.04, 0.1).surely_beyond(0.015)
