"""A law of one's own that sleeps far past its budget once, through the real graph (lockstep): the
controller stops waiting for it, stops the arm on the built-in law and ends with code 3; the run
fails in one line naming the budget, its metrics and bag written, the true angle within the band."""

import numpy as np
import pytest

from robot_controller.scoring.bag_reader import read_recording
from tests.core.laws.test_laws_in_graph import BAND_MARGIN_RAD, ROOT, lockstep_run

pytestmark = pytest.mark.ros

SLEEPS_ONCE = '''
import time

from robot_controller.core.laws import registry

PDWithGravity = registry.resolve("{example}:PDWithGravity")


class SleepsOnce(PDWithGravity):
    """The example's law, asleep for 1 s in its 250th update (2.5 s into the run, a 5 ms budget)."""

    ticks = 0

    def update(self, time_s, state, reference):
        self.ticks += 1
        if self.ticks == 250:
            time.sleep(1.0)
        return super().update(time_s, state, reference)
'''


def test_a_law_asleep_far_past_its_budget_is_stopped_and_the_run_fails_whole(tmp_path, ros_domain):
    law = tmp_path / "sleeps_once.py"
    law.write_text(SLEEPS_ONCE.format(example=ROOT / "examples" / "own_controller.py"))
    proc, out, metrics = lockstep_run(tmp_path, f"{law}:SleepsOnce")
    output = proc.stdout + proc.stderr
    assert proc.returncode != 0, output[-3000:]
    failed = [line for line in proc.stdout.splitlines() if line.startswith("[launcher] FAILED")]
    assert len(failed) == 1, output[-3000:]
    assert "sleeps_once.py:SleepsOnce was still in update()" in failed[0], failed[0]
    assert "over its budget of 5 ms (law_budget_s)" in failed[0] and "built-in lqr" in failed[0], failed[0]
    assert "pid_controller ends (exit code 3)" in output, output[-3000:]
    assert metrics is not None and metrics["law_fault_ticks"] > 0 and metrics["law_stopped_ticks"] >= 1, metrics
    true = read_recording(out / "bag").true_position[:, 0]
    assert np.max(np.abs(true)) <= 1.0 + BAND_MARGIN_RAD, np.max(np.abs(true))  # the sine's band: ±1 rad
