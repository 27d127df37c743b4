"""Laws for the tests: each misbehaves in one way after ``fail_after_s`` seconds."""

import time

import numpy as np

from examples.own_controller import PDWithGravity
from robot_controller.core.laws import Parameter


class RaisesAfter(PDWithGravity):
    parameters = (*PDWithGravity.parameters, Parameter("fail_after_s", 3.0, "when it raises, s", 0.0))

    def update(self, time_s, state, reference):
        if time_s >= self.params["fail_after_s"]:
            raise ZeroDivisionError("the law divided by zero")
        return super().update(time_s, state, reference)


class NaNAfter(RaisesAfter):
    def update(self, time_s, state, reference):
        torque = PDWithGravity.update(self, time_s, state, reference)
        return torque * np.nan if time_s >= self.params["fail_after_s"] else torque


class WrongShapeAfter(RaisesAfter):
    def update(self, time_s, state, reference):
        torque = PDWithGravity.update(self, time_s, state, reference)
        return np.append(torque, 0.0) if time_s >= self.params["fail_after_s"] else torque


class SlowAfter(RaisesAfter):
    def update(self, time_s, state, reference):
        if time_s >= self.params["fail_after_s"]:
            time.sleep(0.02)
        return PDWithGravity.update(self, time_s, state, reference)


class Counting(PDWithGravity):
    """Counts its resets and reports an extra term."""

    state_terms = ("gravity",)

    def __init__(self, arm, period_s, params):
        super().__init__(arm, period_s, params)
        self.resets = 0

    def reset(self, state):
        self.resets += 1

    def terms(self):
        return {"gravity": np.ones(self.arm.joint_count), "p": np.full(self.arm.joint_count, 2.0)}


class PushesAwayAfter(RaisesAfter):
    """Turns its feedback's sign after ``fail_after_s``: finite, in shape, in time, and unstable."""

    def update(self, time_s, state, reference):
        torque = PDWithGravity.update(self, time_s, state, reference)
        if time_s < self.params["fail_after_s"]:
            return torque
        gravity = self.arm.gravity(state.position)
        return gravity - (torque - gravity)
