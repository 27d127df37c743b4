"""The built-in laws, ``pid`` and ``lqr``, as the entry-point group registers
them: one PID implementation (:mod:`~robot_controller.core.laws.pid`) with model
feedforward, the observer's estimate subtracted and, on a chain, decoupled
feedback (:func:`~robot_controller.core.laws.gains.law_step`); for ``lqr`` its gains
come from a Riccati design. Unlike a plugin, they take the node's own
parameters (kp, ki, kd, lqr_q, ...), so they are built from the whole
:class:`ControllerConfig`. The controller also keeps one as the law that
stops the arm when a plugin law fails.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from robot_controller.core.controller.config import ControllerConfig
from robot_controller.core.controller.output import ReferenceSource, Status
from robot_controller.core.controller.reference_at_tick import Reference as TickReference
from robot_controller.core.laws.gains import law_config, law_step
from robot_controller.core.laws.interface import ControlLaw, Reference, State
from robot_controller.core.laws.pid import Pid, PidTerms
from robot_controller.core.model import ArmDynamics


class BuiltinLaw(ControlLaw):
    kind: ClassVar[str] = ""

    def __init__(self, config: ControllerConfig, dynamics: ArmDynamics | None, joint_count: int) -> None:
        self.config = config
        self.dynamics = dynamics
        self.joint_count = joint_count
        self.period_s = config.control_period_s
        self.pid = Pid(law_config(config, dynamics, joint_count, self.kind))
        self._terms: PidTerms | None = None

    @staticmethod
    def of_kind(kind: str, config: ControllerConfig, dynamics: ArmDynamics | None, joint_count: int) -> BuiltinLaw:
        return {"pid": PidLaw, "lqr": LqrLaw}[kind](config, dynamics, joint_count)

    def set_config(self, config: ControllerConfig) -> None:
        """New gains and options, bumpless (the PID keeps its I term in N·m)."""
        self.config = config
        self.pid.set_config(law_config(config, self.dynamics, self.joint_count, self.kind))

    def reset(self, state: State | None = None) -> None:
        self.pid.reset()

    def step(
        self,
        dt_s: float,
        position: np.ndarray,
        velocity: np.ndarray,
        reference: TickReference,
        disturbance: np.ndarray | None,
    ) -> PidTerms:
        """The law over ``dt_s`` with the controller's own reference (its feedforward window included)."""
        self._terms = law_step(self.pid, self.config, self.dynamics, dt_s, position, velocity, reference, disturbance)
        return self._terms

    def update(self, time_s: float, state: State, reference: Reference) -> np.ndarray:
        tick_reference = TickReference(
            reference.position, reference.velocity, reference.acceleration, Status.OK, ReferenceSource.TRAJECTORY
        )
        return self.step(self.period_s, state.position, state.velocity, tick_reference, state.disturbance).command

    def terms(self) -> dict[str, np.ndarray]:
        t = self._terms
        return {} if t is None else {"p": t.p, "i": t.i, "d": t.d, "feedforward": t.feedforward}


class PidLaw(BuiltinLaw):
    """PID with the node's kp, ki, kd."""

    kind = "pid"


class LqrLaw(BuiltinLaw):
    """The same PID, its gains from a discrete LQR design with lqr_q and lqr_r."""

    kind = "lqr"
