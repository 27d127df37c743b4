import itertools
import os

import pytest

_domains = itertools.count()


@pytest.fixture
def ros_domain(monkeypatch) -> int:
    """A ROS_DOMAIN_ID of this test's own, with discovery kept on this host.

    Distinct for every test in a session; the process id spreads concurrent
    sessions over the range.
    """
    domain = 1 + ((os.getpid() % 17) * 5 + next(_domains)) % 100
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    return domain
