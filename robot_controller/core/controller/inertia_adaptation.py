"""The controller kept on the arm's real inertia (:class:`InertiaAdaptation`): the inertia each joint has beyond its
model (:class:`~robot_controller.core.estimation.inertia.InertiaEstimate`) is added to the controller's model as
rotor inertia (MuJoCo's armature: the filter's prediction, the observer, the feedforward and the decoupling all read
it), and the built-in law's gains are raised with each joint's design inertia, so the loop keeps its bandwidth.

Why both: a Panda wrist with 0.1 kg·m² of armature (16 times its own 0.0067) makes the observer on the lighter model
oscillate (115 mrad); told the armature the filter tracks again, but the gains designed for the lighter joint leave
its friction's reversals 13 mrad; with the gains scaled, 3.5."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from robot_controller.core.estimation.inertia import InertiaEstimate
from robot_controller.core.laws.pid import PAYLOAD_INERTIA_RATIO, Pid
from robot_controller.core.model import payload

if TYPE_CHECKING:
    from robot_controller.core.controller.config import ControllerConfig
    from robot_controller.core.estimation import JointKalmanFilter
    from robot_controller.core.laws.pid import PidConfig
    from robot_controller.core.model import ArmDynamics

#: the gains are set again once a joint's factor has moved by this share (setting them takes a dataclass's checks)
GAIN_STEP = 0.005


class InertiaAdaptation:
    """:param model: the controller's MuJoCo model (``ArmDynamics.model``), its ``dof_armature`` written to
    :param own_inertia: kg·m² per joint, the model's own at the design pose (before anything is added)
    :param payload_bound: kg·m² per joint, what the rated payload may add there (the gains' design allows for it)
    :param pid: gives the built-in law's PID, whose gains are scaled
    """

    def __init__(self, model, own_inertia: np.ndarray, payload_bound: np.ndarray, pid: Callable[[], Pid]) -> None:
        n = len(own_inertia)
        self.estimate = InertiaEstimate(own_inertia)
        self._model, self._dofs = model, model.jnt_dofadr[:n]
        self._armature = model.dof_armature[self._dofs].copy()  #: the URDF's (or model_inertia's)
        self._own, self._payload_bound = np.asarray(own_inertia, float), np.asarray(payload_bound, float)
        self._pid = pid
        self._designed: PidConfig | None = None  #: the gains as designed, before any scaling
        self._scaled: PidConfig | None = None  #: the gains last set here
        self._scale = np.ones(n)  #: their factor on the designed ones

    @classmethod
    def build(
        cls, config: ControllerConfig, dynamics: ArmDynamics | None, joint_count: int, pid: Callable[[], Pid]
    ) -> InertiaAdaptation | None:
        """For a controller with the disturbance observer on a coupled MuJoCo model, in lockstep (on the wall clock the
        filter disagrees with its readings by design, and nothing would tell an inertia from the command's jitter);
        None otherwise."""
        model = getattr(dynamics, "model", None)
        if model is None or not (config.inertia_adaptation and config.observes_disturbance and config.lockstep):
            return None
        pose = np.zeros(joint_count) if config.design_position is None else np.asarray(config.design_position, float)
        own = np.diag(dynamics.mass_matrix(pose)).copy()
        bound = payload.inertia_bound(model, config.rated_payload_kg, pose) if config.rated_payload_kg > 0 else None
        return cls(model, own, np.zeros(joint_count) if bound is None else bound, pid)

    def after_reading(self, time_s: float, kalman: JointKalmanFilter) -> None:
        """Take the filter's state after the reading at ``time_s``; move the model and the gains with the estimate."""
        if kalman.x is None or not kalman.estimates_disturbance:
            self.estimate.restart()
            return
        before = self.estimate.extra
        extra = self.estimate.update(time_s, kalman.x[:, 1], kalman.disturbance, kalman.disagreeing)
        if np.array_equal(extra, before):  # (an arm that agrees with its model: never anything to do)
            return
        self._model.dof_armature[self._dofs] = self._armature + extra
        pid = self._pid()
        if pid.config is not self._scaled:  # new gains (set at run time): those are the design now
            self._designed = pid.config
        scale = self._design(self._own + extra) / self._design(self._own)
        if pid.config is self._scaled and np.all(np.abs(scale - self._scale) <= GAIN_STEP * self._scale):
            return
        self._scale, designed = scale, self._designed
        self._scaled = replace(designed, kp=designed.kp * scale, ki=designed.ki * scale, kd=designed.kd * scale)
        pid.set_config(self._scaled)

    def _design(self, own: np.ndarray) -> np.ndarray:
        """The inertia the gains are designed for, as :func:`~robot_controller.core.laws.pid.design_inertia`."""
        return np.minimum(own + self._payload_bound, PAYLOAD_INERTIA_RATIO * own)
