"""The built-in laws, ``pid`` and ``lqr``: :class:`ControlLaw`\\ s like a user's, built with the
arm, the period and their parameters (the node's kp, ki, kd, lqr_q, ... as
:meth:`~robot_controller.core.controller.config.ControllerConfig.law_params` gives them).
One :class:`~robot_controller.core.laws.pid.Pid` runs both: model feedforward for the
reference over the period, less the observer's estimate of an external torque, plus
feedback (decoupled on a chain, :func:`decoupling_map`); for ``lqr`` the gains come from a
Riccati design.

Gains: Kp N·m/rad, Ki N·m/(rad·s), Kd N·m·s/rad; torques N·m; times s.
"""

from __future__ import annotations

from collections.abc import Mapping
from enum import StrEnum
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from robot_controller.core.laws.interface import Arm, ControlLaw, Reference, State
from robot_controller.core.laws.lqr import designed_gains
from robot_controller.core.laws.pid import Pid, PidConfig, PidTerms

if TYPE_CHECKING:
    from robot_controller.core.model import ArmDynamics


class FeedforwardMode(StrEnum):
    """The model feedforward the built-in law adds for the reference."""

    NONE = "none"
    GRAVITY = "gravity"  #: gravity at the reference position
    FULL = "full"  #: inertia·a_ref + damping·v_ref + gravity(q_ref)


def feedforward_torque(
    mode: FeedforwardMode,
    dynamics: ArmDynamics | None,
    position: np.ndarray,
    velocity: np.ndarray,
    acceleration: np.ndarray,
) -> np.ndarray:
    """Feedforward torque (N·m) for the reference ``(position, velocity, acceleration)``."""
    if mode is FeedforwardMode.NONE or dynamics is None:
        return np.zeros(np.shape(position))
    if mode is FeedforwardMode.GRAVITY:
        return dynamics.gravity(position)
    return dynamics.torque(position, velocity, acceleration)


def decoupling_map(decoupling: bool, dynamics: ArmDynamics | None, position: np.ndarray) -> np.ndarray | None:
    """``M(q)·diag(M(q))⁻¹`` at ``position``: the torques that give each joint the acceleration its
    own gains ask for (``τ_j / M_jj``) on a chain whose inertias couple (the feedback half of
    computed-torque control). None when ``decoupling`` is off, on one joint or without the arm model."""
    if not decoupling or dynamics is None or np.size(position) < 2:
        return None
    mass = dynamics.mass_matrix(position)
    return mass / np.diag(mass)[None, :]


# A tick later than this many periods after the last one is integrated over this many.
MAX_STEP_PERIODS = 5


class BuiltinLaw(ControlLaw):
    """Params: ``pid`` (a :class:`PidConfig`), ``feedforward`` (a FeedforwardMode),
    ``feedback_decoupling``, ``lqr_q``, ``lqr_r``, ``reference_inertia``, ``design_position``."""

    kind: ClassVar[str] = ""

    def __init__(self, arm: Arm, period_s: float, params: Mapping[str, Any]) -> None:
        super().__init__(arm, period_s, params)
        self.pid = Pid(self.gains())
        self._terms: PidTerms | None = None
        self._last_s: float | None = None

    @staticmethod
    def of_kind(kind: str, arm: Arm, period_s: float, params: Mapping[str, Any]) -> BuiltinLaw:
        return {"pid": PidLaw, "lqr": LqrLaw}[kind](arm, period_s, params)

    def gains(self) -> PidConfig:
        """The PID settings this law runs with (for LQR, the designed gains); ``ConfigError`` if none."""
        p = self.params
        if self.kind == "pid":
            return p["pid"]
        return designed_gains(
            p["pid"],
            self.arm.model,
            self.arm.joint_count,
            self.period_s,
            p["lqr_q"],
            p["lqr_r"],
            p["reference_inertia"],
            p["design_position"],
        )

    def set_params(self, params: Mapping[str, Any]) -> None:
        """New gains and options, bumpless (the PID keeps its I term in N·m)."""
        self.params = dict(params)
        self.pid.set_config(self.gains())

    def reset(self, state: State | None = None) -> None:
        self.pid.reset()
        self._last_s = None

    def update(self, time_s: float, state: State, reference: Reference) -> np.ndarray:
        """Feedforward for ``reference.ahead`` less ``state.disturbance``, plus the PID's feedback over
        the time since the last update (the period on the first, at most MAX_STEP_PERIODS)."""
        dt_s = self.period_s
        if self._last_s is not None and time_s > self._last_s:
            dt_s = min(time_s - self._last_s, MAX_STEP_PERIODS * self.period_s)
        self._last_s = time_s
        model = self.arm.model
        feedforward = feedforward_torque(self.params["feedforward"], model, *reference.ahead) - state.disturbance
        self._terms = self.pid.step(
            dt_s,
            reference.position,
            reference.velocity,
            state.position,
            state.velocity,
            feedforward,
            decoupling_map(self.params["feedback_decoupling"], model, state.position),
        )
        return self._terms.command

    def terms(self) -> dict[str, np.ndarray]:
        t = self._terms
        if t is None:
            return {}
        return {
            "command": t.command,
            "p": t.p,
            "i": t.i,
            "d": t.d,
            "feedforward": t.feedforward,
            "saturated": t.saturated,
        }

    def describe(self, observer: str = "") -> str:
        """One line for a log or a status topic: the law, the gains in force with their units, the
        torque limit, the feedforward and ``observer`` (a clause on the disturbance observer). In LQR
        mode it says so, and that the kp/ki/kd parameters are unused (the design replaced them)."""
        gains, p = self.pid.config, self.params
        in_force = (
            f"Kp={_values(gains.kp)} N·m/rad, Ki={_values(gains.ki)} N·m/(rad·s), "
            f"Kd={_values(gains.kd)} N·m·s/rad, D on {gains.derivative_source.value}, "
            f"|torque| <= {_values(gains.output_limit)} N·m, feedforward {p['feedforward'].value}{observer}"
        )
        if self.kind == "lqr":
            return (
                f"LQR (q={_values(p['lqr_q'])}, r={p['lqr_r']:g}, designed at "
                f"{1.0 / self.period_s:g} Hz): {in_force}; the kp/ki/kd parameters are unused"
            )
        return f"PID: {in_force}"


class PidLaw(BuiltinLaw):
    """PID with the node's kp, ki, kd."""

    kind = "pid"


class LqrLaw(BuiltinLaw):
    """The same PID, its gains from a discrete LQR design with lqr_q and lqr_r."""

    kind = "lqr"


def _values(values: np.ndarray | tuple[float, ...]) -> str:
    return "[" + ", ".join(f"{float(v):.3g}" for v in np.atleast_1d(values)) + "]"
