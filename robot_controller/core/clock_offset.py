"""Two hosts' clock offset from stamps taken both ways, as NTP does: this host stamps a request when sent (t1) and
its reply when received (t4), the other host the request's arrival (t2) and the reply's departure (t3). The offset
(theirs minus ours) is ((t2 - t1) + (t3 - t4)) / 2, right to within half the round trip (t4 - t1) - (t3 - t2)."""

from __future__ import annotations

from dataclasses import dataclass
from statistics import median


@dataclass(frozen=True)
class ClockOffset:
    offset_s: float  #: the other host's clock minus this host's, s
    round_trip_s: float  #: the exchange's time on the wire, s

    def surely_beyond(self, limit_s: float) -> bool:
        """More than ``limit_s`` apart however lopsided the link."""
        return abs(self.offset_s) - self.round_trip_s / 2 > limit_s


def estimate(exchanges: list[tuple[float, float, float, float]]) -> ClockOffset:
    """The median offset and round trip of the quicker half of ``exchanges`` (t1, t2, t3, t4 in s): a slow
    exchange waited in a queue one way, which skews its offset. ValueError if there is none."""
    found = [(((t2 - t1) + (t3 - t4)) / 2, (t4 - t1) - (t3 - t2)) for t1, t2, t3, t4 in exchanges]
    quick = sorted(found, key=lambda s: s[1])[: max(1, len(found) // 2)]
    return ClockOffset(median(s[0] for s in quick), median(s[1] for s in quick))
