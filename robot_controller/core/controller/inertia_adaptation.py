"""The controller kept on the arm's real inertia (:class:`InertiaAdaptation`): the inertia each joint has beyond its
model (:class:`InertiaEstimate`) is added to the controller's model as rotor inertia (MuJoCo's armature, which the
filter, the observer, the feedforward and the decoupling all read), and the built-in law's gains are raised with
each joint's design inertia, so the loop keeps its bandwidth. Why both: a Panda wrist with 0.1 kg·m² of armature
(16 times its own) makes the observer on the lighter model oscillate (115 mrad); told the armature, the gains
designed for the lighter joint leave its friction's reversals 13 mrad; with the gains scaled, 3.5.

It cannot run away: the gains are always the design on the nominal model times one factor per joint (a redesign
never compounds with the factor); every factor is cut back until the delay margin holds on the inertia learnt; the
estimate is bounded per joint and learns only from readings where the observer's torque can be the arm's inertia
(not while a push acts, at the torque limit, or after a restart of the filter)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from robot_controller.core.controller.supervision import joint_delay_margins
from robot_controller.core.estimation.inertia import InertiaEstimate
from robot_controller.core.laws.pid import PAYLOAD_INERTIA_RATIO, Pid
from robot_controller.core.model import payload

if TYPE_CHECKING:
    from robot_controller.core.controller.config import ControllerConfig
    from robot_controller.core.estimation import JointKalmanFilter
    from robot_controller.core.laws.pid import PidConfig
    from robot_controller.core.model import ArmDynamics

#: the gains are set again once a joint's factor has moved by this share (each setting checks the delay margin)
GAIN_STEP = 0.02
#: a change of the gains in force is said (:meth:`InertiaAdaptation.notes`) once a joint's factor has moved this share
#: from the one last said
SAID_STEP = 0.1
#: a joint's observer torque this share of its torque limit away from where it was before a jump the filter took is an
#: external torque still acting (a push, one held): nothing is learnt until it is gone
PUSH_SHARE = 0.1
#: s, over about how long the observer's torque is averaged to tell a torque that stays (a push) from an oscillation
PUSH_AVERAGE_S = 0.5
#: halvings of a factor towards 1 looked for when the delay margin refuses it
MARGIN_STEPS = 6


class InertiaAdaptation:
    """``dynamics``' ``model.dof_armature`` is written to (``learnt_armature``: how much of it is learnt);
    ``own_inertia`` and ``payload_bound`` (kg·m² per joint, at the design pose) are what the gains are designed for;
    ``pid`` and ``config`` give the PID whose gains are scaled and the configuration in force."""

    def __init__(
        self,
        dynamics: ArmDynamics,
        own_inertia: np.ndarray,
        payload_bound: np.ndarray,
        pid: Callable[[], Pid],
        config: Callable[[], ControllerConfig],
    ) -> None:
        n = len(own_inertia)
        self.estimate = InertiaEstimate(own_inertia)
        self._dynamics = dynamics
        model = dynamics.model
        self._model, self._dofs = model, model.jnt_dofadr[:n]
        self._armature = model.dof_armature[self._dofs].copy()  #: the URDF's (or model_inertia's)
        self._own, self._payload_bound = np.asarray(own_inertia, float), np.asarray(payload_bound, float)
        self._own_design = self._design(self._own)  #: kg·m² per joint, what the designed gains are for
        self._pid, self._config = pid, config
        self._designed: PidConfig | None = None  #: the gains as designed, before any scaling
        self._scaled: PidConfig | None = None  #: the gains last set here
        self._scale = np.ones(n)  #: their factor on the designed ones
        self._said = np.ones(n)  #: the factor last said in a note
        self._notes: list[str] = []
        self._jumps: list[int] | None = None  #: the filter's jump and restart counts at the last reading
        self._before_push: list[float] | None = None  #: the observer's torque before the last jump, while it acts
        #: the observer's torque per joint averaged over PUSH_AVERAGE_S, and when
        self._slow_torque: tuple[list[float], float] | None = None

    @classmethod
    def build(
        cls,
        config: ControllerConfig,
        dynamics: ArmDynamics | None,
        joint_count: int,
        pid: Callable[[], Pid],
        config_in_force: Callable[[], ControllerConfig] | None = None,
    ) -> InertiaAdaptation | None:
        """For the disturbance observer on a MuJoCo model where the world waits (on the wall clock nothing would tell
        an inertia from the command's jitter); None otherwise."""
        model = getattr(dynamics, "model", None)
        if model is None or not (config.inertia_adaptation and config.observes_disturbance and config.world_waits):
            return None
        pose = np.zeros(joint_count) if config.design_position is None else np.asarray(config.design_position, float)
        own = np.diag(dynamics.mass_matrix(pose)) - dynamics.learnt_armature
        bound = payload.inertia_bound(model, config.rated_payload_kg, pose) if config.rated_payload_kg > 0 else None
        payload_bound = np.zeros(joint_count) if bound is None else bound
        return cls(dynamics, own, payload_bound, pid, config_in_force or (lambda: config))

    @property
    def armature(self) -> np.ndarray:
        """kg·m² per joint, the armature learnt (added to the model's own)."""
        return self.estimate.extra.copy()

    @property
    def inertia(self) -> np.ndarray:
        """kg·m² per joint, the inertia at the design pose the gains in force are for: the own and the learnt."""
        return self._own + self.estimate.extra

    @property
    def scale(self) -> np.ndarray:
        """Per joint, the factor on the designed gains in force."""
        return self._scale.copy()

    def describe(self) -> str:
        """A clause for ``law_in_force``: the gains above are the design times these factors, for this armature."""
        factors = ", ".join(f"{s:.3g}" for s in self._scale)
        armature = ", ".join(f"{a:.3g}" for a in self.estimate.extra)
        return f"; inertia adaptation: gains × [{factors}] of the design for armature [{armature}] kg·m² learnt"

    def notes(self) -> list[str]:
        """What changed in the gains since the last call, one line each (for the log), then forgotten."""
        notes, self._notes = self._notes, []
        return notes

    def interrupted(self) -> None:
        """The filter starts again (a stop, the brakes, an e-stop, a fault): so does the estimate's evidence."""
        self.estimate.restart()
        self._jumps = self._before_push = self._slow_torque = None

    def after_reading(self, time_s: float, kalman: JointKalmanFilter, command: np.ndarray | None = None) -> None:
        """Take the filter's state after the reading at ``time_s`` (``command``: N·m, the torque that acted up to it);
        move the model and the gains with the estimate."""
        if kalman.x is None or not kalman.estimates_disturbance:
            self.interrupted()
            return
        torque = kalman.disturbance
        blocked = self._blocked(time_s, kalman, torque)
        limit = np.asarray(self._config().pid.output_limit, float)
        # (count_nonzero: any() and all() cost five times as much on a few joints)
        saturated = command is not None and np.count_nonzero(np.abs(command) >= limit * (1.0 - 1e-9)) > 0
        before = self.estimate.extra  # (the estimate's update makes a new array)
        extra = self.estimate.update(time_s, kalman.x[:, 1], torque, kalman.disagreeing, blocked, saturated)
        pid = self._pid()
        if pid.config is self._scaled and np.count_nonzero(extra == before) == extra.size:
            return  # (an arm that agrees with its model: never anything to do)
        self._model.dof_armature[self._dofs] = self._armature + extra
        self._dynamics.learnt_armature = extra.copy()
        redesigned = pid.config is not self._scaled
        if redesigned:  # new gains (set at run time, designed on the nominal model): the design, scaled from here
            self._designed = pid.config
        wanted = self._design(self._own + extra) / self._own_design
        if not redesigned and np.all(np.abs(wanted - self._scale) <= GAIN_STEP * self._scale):
            return
        self._set(pid, self._within_margin(wanted, self._own + extra, redesigned))

    def _blocked(self, time_s: float, kalman: JointKalmanFilter, torque: np.ndarray) -> bool:
        """Whether the observer's torque cannot be the arm's inertia: the filter took a jump or restarted a joint,
        and the torque's slow part (an inertia's averages out) is still away from where it was before."""
        counts = kalman.jump_count.tolist() + kalman.restart_count.tolist()
        jumped = self._jumps is not None and counts != self._jumps
        self._jumps = counts
        last = self._slow_torque
        if last is None:
            self._slow_torque = (torque.tolist(), time_s)
        else:  # (on Python's floats: a few joints, where a NumPy call costs more than its arithmetic)
            weight = min(max(time_s - last[1], 0.0) / PUSH_AVERAGE_S, 1.0)
            self._slow_torque = ([s + weight * (x - s) for s, x in zip(last[0], torque.tolist(), strict=True)], time_s)
        if jumped and self._before_push is None and last is not None:
            self._before_push = last[0]
        if self._before_push is None:
            return False
        limit = np.asarray(self._config().pid.output_limit, float)
        if np.all(np.abs(np.subtract(self._slow_torque[0], self._before_push)) <= PUSH_SHARE * limit):
            self._before_push = None  # none that stays (an oscillation's), or gone: the evidence starts again from here
            return False
        return True

    def _within_margin(self, wanted: np.ndarray, inertia: np.ndarray, every: bool = False) -> np.ndarray:
        """``wanted`` with each changed joint's factor (``every``: all) cut back towards 1 until its delay margin on
        ``inertia`` holds."""
        config, designed = self._config(), self._designed
        needed = config.min_delay_margin_periods
        # A factor of 1 is the design itself, which nothing cuts back (the search between 1 and 1 ends at 1): its
        # margins are not worked out (on the Panda, 14 Riccati equations at the first reading, the estimate still 0).
        changed = np.flatnonzero(((wanted != self._scale) | every) & (wanted != 1.0))
        if needed <= 0 or not changed.size:
            return wanted
        scale = wanted.copy()
        for j in changed.tolist():
            low, high = 1.0, wanted[j]
            for _ in range(MARGIN_STEPS + 1):
                gains = replace(designed, kp=designed.kp * high, ki=designed.ki * high, kd=designed.kd * high)
                margin = joint_delay_margins(gains, self._dynamics, len(wanted), config, inertia, needed, [j])[0]
                if margin >= needed:
                    break
                high = low + 0.5 * (high - low)
            else:
                high = low
            scale[j] = high
        return scale

    def _set(self, pid: Pid, scale: np.ndarray) -> None:
        """Put the designed gains times ``scale`` in force; say so once a factor has moved by SAID_STEP."""
        self._scale, designed = scale, self._designed
        self._scaled = replace(designed, kp=designed.kp * scale, ki=designed.ki * scale, kd=designed.kd * scale)
        pid.set_config(self._scaled)
        moved = np.abs(scale - self._said) > SAID_STEP * self._said
        if np.any(moved):
            said = ", ".join(
                f"{self._dynamics.joint_names[j]} ×{scale[j]:.3g} (was ×{self._said[j]:.3g}; "
                f"armature {self.estimate.extra[j]:.3g} kg·m²)"
                for j in np.flatnonzero(moved)
            )
            self._notes.append(f"inertia adaptation: gains in force now the design {said}")
            self._said = np.where(moved, scale, self._said)

    def _design(self, own: np.ndarray) -> np.ndarray:
        """The inertia the gains are designed for, as :func:`~robot_controller.core.laws.pid.design_inertia`."""
        return np.minimum(own + self._payload_bound, PAYLOAD_INERTIA_RATIO * own)
