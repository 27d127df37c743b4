"""franka-sim's venv for the tests that drive the stand-in Franka robot: made by ``make franka-sim`` when missing, or
the test says why it skips."""

import subprocess
from pathlib import Path

import pytest

from robot_controller.hardware import franka_server

REPO = Path(__file__).resolve().parents[2]


def stand_in_venv() -> Path:
    venv = franka_server.default_venv()
    if not (venv / ".installed").is_file():
        made = subprocess.run(["make", "-C", str(REPO), "franka-sim"], capture_output=True, text=True, timeout=900)
        if not (venv / ".installed").is_file():
            pytest.skip(f"franka-sim's venv is missing and `make franka-sim` could not make it: {made.stderr[-300:]}")
    return venv


#: ms: a tick's 99th percentile beyond the robot's 1 ms period is a host that cannot keep the robot's clock
SLOW_TICK_P99_MS = 1.0
#: the robot's own count: a window of 100 commands with fewer than this share in time is a moment the host (or the
#: link) could not keep 1 kHz
HELD_SHARE = 0.95


def skip_on_a_host_too_slow(said: str, tick_p99_ms: float | None) -> None:
    """Skip, saying why, when the robot stopped the run for late commands (communication_constraints_violation, its
    defined reaction) and our tick's 99th percentile passed its period: this host cannot keep 1 kHz (2026-12-06's
    kept it, p99 0.78-0.84 ms; tick time is the bench's to judge, never a test's)."""
    if "communication_constraints_violation" in said and tick_p99_ms is not None and tick_p99_ms > SLOW_TICK_P99_MS:
        pytest.skip(
            f"this host computed our tick in {tick_p99_ms:.2f} ms (99th percentile), past the robot's 1 ms, and the "
            "robot stopped the run for late commands (communication_constraints_violation), as it must: a host that "
            "keeps 1 kHz runs this test"
        )


def skip_on_a_host_that_faltered(said: str, metrics: dict | None) -> None:
    """Skip, saying why, a failed run in which the robot counted a window of 100 commands with fewer than HELD_SHARE
    in time: the host stalled the loop at that moment (on 2 shared cores, the robot's server and our 1 kHz drive take
    a core each, and the graph around them came late: a goal aborted for a stale state, a stop for a reference lost,
    the robot's own stop). A host that holds 1 kHz through the run runs this test whole."""
    low = None if metrics is None else metrics.get("command_success_rate_min")
    if low is not None and low < HELD_SHARE:
        failed = next((line.strip() for line in said.splitlines() if "FAILED" in line), "the run failed")
        pytest.skip(
            f"this host stalled the 1 kHz loop: the robot took only {low:.2f} of a window of 100 commands in time "
            f"(held is {HELD_SHARE}), and the run failed with it ({failed[:200]})"
        )
