"""A node process whose DDS teardown hangs, holding the GIL, after its work was done
ends by its own alarm (the launcher warns and keeps the run) and says where it hung."""

import signal
import subprocess
import sys
import textwrap

import pytest

from robot_controller.ros.process import TEARDOWN_HUNG_SIGNAL

pytestmark = pytest.mark.ros

# A node that stops itself at once; its destroy_node then sits in the regex engine,
# which holds the GIL as a stuck C call in a DDS teardown would.
HANGING_NODE = textwrap.dedent(
    """
    import re
    from robot_controller.ros.process import request_exit, run
    from robot_controller.ros.adapter import BlockNode

    class HangsOnTheWayOut(BlockNode):  # a subclass for the test's hang only
        def __init__(self):
            super().__init__("sensor_node")
            self.create_timer(0.05, lambda: request_exit(0))

        def destroy_node(self):
            re.match(r"(a+)+$", "a" * 64 + "b")  # backtracks for hours without letting go of the GIL

    raise SystemExit(run(HangsOnTheWayOut))
    """
)


def test_a_teardown_hung_holding_the_gil_ends_by_its_alarm(ros_domain):
    proc = subprocess.run([sys.executable, "-c", HANGING_NODE], capture_output=True, text=True, timeout=60)
    assert proc.returncode == -TEARDOWN_HUNG_SIGNAL, proc.stderr[-2000:]
    assert TEARDOWN_HUNG_SIGNAL != signal.SIGINT
    assert "destroy_node" in proc.stderr  # faulthandler's dump: where it hung
