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
