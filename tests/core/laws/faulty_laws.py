"""Laws for the tests of plugin laws through the graph: the example's PD with gravity, each
failing in one way after ``fail_after_ticks`` updates (counted, so the same on either clock).
Named in ``controller_type`` as ``tests/core/laws/faulty_laws.py:Class``."""

import time
from pathlib import Path

import numpy as np

from robot_controller.core.laws import Parameter, registry

EXAMPLE = Path(__file__).resolve().parents[3] / "examples" / "own_controller.py"
# By its file, as a user names it: importable from any working directory.
PDWithGravity = registry.resolve(f"{EXAMPLE}:PDWithGravity")


class RaisesAfter(PDWithGravity):
    """Raises after ``fail_after_ticks`` updates; reports its gravity torque as an extra term."""

    parameters = (
        *PDWithGravity.parameters,
        Parameter("fail_after_ticks", 400.0, "updates before it fails", 0.0, 1e9),
    )
    state_terms = ("gravity",)

    def __init__(self, arm, period_s, params):
        super().__init__(arm, period_s, params)
        self.ticks = 0

    def failing(self) -> bool:
        self.ticks += 1
        return self.ticks > self.params["fail_after_ticks"]

    def update(self, time_s, state, reference):
        if self.failing():
            raise ZeroDivisionError("the law divided by zero")
        self.gravity = self.arm.gravity(state.position)
        return super().update(time_s, state, reference)

    def terms(self):
        return {"gravity": getattr(self, "gravity", np.zeros(self.arm.joint_count))}


class NaNAfter(RaisesAfter):
    """Returns NaN after ``fail_after_ticks`` updates."""

    def update(self, time_s, state, reference):
        torque = PDWithGravity.update(self, time_s, state, reference)
        return torque * np.nan if self.failing() else torque


class SlowAfter(RaisesAfter):
    """Computes for 8 ms of its thread's CPU time per update after ``fail_after_ticks`` updates (the budget is
    5 ms; a law that sleeps uses none, and only a long sleep is a fault where the world waits for the law)."""

    def update(self, time_s, state, reference):
        if self.failing():
            until_s = time.thread_time() + 0.008
            while time.thread_time() < until_s:
                pass
        return PDWithGravity.update(self, time_s, state, reference)


class PushesAwayAfter(RaisesAfter):
    """Turns its feedback's sign after ``fail_after_ticks`` updates: finite, in time, and unstable."""

    def update(self, time_s, state, reference):
        torque = PDWithGravity.update(self, time_s, state, reference)
        if not self.failing():
            return torque
        gravity = self.arm.gravity(state.position)
        return gravity - (torque - gravity)
