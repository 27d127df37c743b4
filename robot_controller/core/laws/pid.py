"""The built-in PID law: its settings (:class:`PidConfig`), one step (:class:`Pid`, reporting :class:`PidTerms`),
and the law the controller runs it as (:class:`BuiltinLaw`, a ``ControlLaw`` like a user's): model feedforward for
the reference over the period, less the observer's external torque, plus feedback (decoupled on a chain). The LQR
is the same law with designed gains (:mod:`.lqr`).

Arrays have one entry per joint and broadcast, so a batch of gain sets ``(batch, n)`` runs through the same code.
The integral is stored as the I term itself (N·m), so a new ``ki`` while running does not kick the output.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from enum import StrEnum
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.laws.interface import Arm, ControlLaw, Reference, State
from robot_controller.core.metrics import in_units
from robot_controller.core.model import payload
from robot_controller.core.model.mujoco_model import position_ranges

if TYPE_CHECKING:
    from robot_controller.core.model import ArmDynamics


class AntiWindup(StrEnum):
    """How the integral is kept from winding up while the output saturates."""

    NONE = "none"
    CLAMP = "clamp"  #: |∫e dt| ≤ integral_limit (rad·s), the tutorial's clamp
    BACK_CALCULATION = "back_calculation"  #: bleed (u_sat − u)/Tt into the I term
    CONDITIONAL_INTEGRATION = "conditional_integration"  #: freeze while saturated and error pushes further out


class DerivativeSource(StrEnum):
    """What the D term differentiates."""

    MEASURED_VELOCITY = "measured_velocity"  #: −v_measured, the tutorial's choice
    VELOCITY_ERROR = "velocity_error"  #: v_reference − v_measured
    ERROR = "error"  #: finite difference of the position error
    MEASUREMENT = "measurement"  #: −finite difference of the measured position


@dataclass
class PidConfig:
    """Gains and options of :class:`Pid`, every one given (the defaults are the parameter schema's); per joint
    where an array."""

    kp: np.ndarray  #: N·m/rad
    ki: np.ndarray  #: N·m/(rad·s)
    kd: np.ndarray  #: N·m·s/rad
    output_limit: np.ndarray  #: N·m (> 0), symmetric
    integral_limit: np.ndarray  #: rad·s, the clamp on ∫e dt (``clamp``)
    anti_windup: AntiWindup
    back_calculation_time_s: float  #: s, back-calculation's tracking time constant Tt
    derivative_source: DerivativeSource
    derivative_filter_time_s: float  #: s, the D signal's first-order low-pass (0: off)
    slew_rate_limit: float  #: N·m/s, max |du/dt| (0: off)

    def __post_init__(self) -> None:
        for name in ("kp", "ki", "kd", "output_limit", "integral_limit"):
            value = np.atleast_1d(np.asarray(getattr(self, name), dtype=float))
            if not np.all(np.isfinite(value)):
                raise ConfigError(f"{name}: must be finite, got {value.tolist()}")
            if np.any(value < 0):
                raise ConfigError(f"{name}: must be >= 0, got {value.tolist()}")
            setattr(self, name, value)
        if np.any(self.output_limit <= 0):
            raise ConfigError(f"output_limit: must be > 0, got {self.output_limit.tolist()}")
        for name, kind in (("anti_windup", AntiWindup), ("derivative_source", DerivativeSource)):
            try:
                setattr(self, name, kind(getattr(self, name)))
            except ValueError:
                raise ConfigError(f"{name}: {getattr(self, name)!r} is not one of {[m.value for m in kind]}") from None
        for name in ("back_calculation_time_s", "derivative_filter_time_s", "slew_rate_limit"):
            value = float(getattr(self, name))
            if not np.isfinite(value) or value < 0:
                raise ConfigError(f"{name}: must be a finite number >= 0, got {value}")
            setattr(self, name, value)
        if self.anti_windup is AntiWindup.BACK_CALCULATION and self.back_calculation_time_s <= 0:
            raise ConfigError("back_calculation_time_s: must be > 0 with anti_windup back_calculation")


@dataclass
class PidTerms:
    """One step's output and its parts, for tuning plots (all N·m except ``saturated``)."""

    command: np.ndarray
    p: np.ndarray
    i: np.ndarray
    d: np.ndarray
    feedforward: np.ndarray
    saturated: np.ndarray  #: bool per joint: the limit (output or slew) cut the command


class Pid:
    """A discrete PID law, called once per control period with explicit ``dt``: ``u = ff + kp·e + I + kd·D``,
    ``e = r − y``, saturated to ``±output_limit`` and, if set, slew-rate limited. Non-finite inputs give a zero
    command and leave the state untouched: the arm never gets a non-finite torque."""

    def __init__(self, config: PidConfig) -> None:
        self.config = config
        self.reset()

    def reset(self) -> None:
        """Forget the integral, filter and derivative history."""
        self._i_term = np.zeros_like(self.config.kp, dtype=float)
        self._d_filtered: np.ndarray | None = None
        self._prev_error: np.ndarray | None = None
        self._prev_position: np.ndarray | None = None
        self._prev_command: np.ndarray | None = None

    def set_config(self, config: PidConfig) -> None:
        """Swap gains and options while running, bumplessly (the I term is kept in N·m)."""
        self.config = config
        self._i_term = np.broadcast_to(self._i_term, np.broadcast_shapes(self._i_term.shape, config.kp.shape)).copy()

    @property
    def integral_term(self) -> np.ndarray:
        """The current I term, N·m."""
        return self._i_term.copy()

    def step(
        self,
        dt: float,
        reference_position: np.ndarray,
        reference_velocity: np.ndarray,
        measured_position: np.ndarray,
        measured_velocity: np.ndarray,
        feedforward: np.ndarray | float = 0.0,
        feedback_map: np.ndarray | None = None,
    ) -> PidTerms:
        """Advance one control period of ``dt`` s. ``feedback_map`` (n × n): the feedback torques pass through it
        before the feedforward is added and the command limited; the terms reported are the joints' own."""
        c = self.config
        shape = np.shape(reference_position)
        if shape != c.kp.shape:
            shape = np.broadcast_shapes(shape, c.kp.shape)
        # Every input finite: their sum is (inf − inf is NaN; a finite sum past 1e308 is refused too).
        total = reference_position + reference_velocity + measured_position + measured_velocity + feedforward
        finite = np.isfinite(total)
        if not (math.isfinite(dt) and dt > 0) or np.count_nonzero(finite) != finite.size:
            zeros = np.zeros(shape)
            return PidTerms(zeros, zeros, zeros, zeros, zeros, np.zeros(shape, dtype=bool))

        error = reference_position - measured_position
        p_term = c.kp * error
        if c.derivative_source is DerivativeSource.MEASURED_VELOCITY:
            d_signal = -measured_velocity
        elif c.derivative_source is DerivativeSource.VELOCITY_ERROR:
            d_signal = reference_velocity - measured_velocity
        elif c.derivative_source is DerivativeSource.ERROR:
            d_signal = np.zeros(shape) if self._prev_error is None else (error - self._prev_error) / dt
        else:  # MEASUREMENT
            previous = self._prev_position
            d_signal = np.zeros(shape) if previous is None else -(measured_position - previous) / dt
        self._prev_error = error  # (a new array: never written to)
        self._prev_position = np.array(measured_position, dtype=float)
        if c.derivative_filter_time_s > 0:
            if self._d_filtered is None:
                self._d_filtered = np.array(d_signal, dtype=float)
            else:
                alpha = dt / (c.derivative_filter_time_s + dt)
                self._d_filtered = self._d_filtered + alpha * (d_signal - self._d_filtered)
            d_signal = self._d_filtered
        d_term = c.kd * d_signal
        feedforward = np.asarray(feedforward, dtype=float)
        if feedforward.shape != shape:
            feedforward = np.broadcast_to(feedforward, shape)

        # Integrate, then limit per the anti-windup mode.
        i_candidate = self._i_term + c.ki * error * dt
        if c.anti_windup is AntiWindup.CLAMP:
            i_limit = c.ki * c.integral_limit
            i_candidate = np.minimum(np.maximum(i_candidate, -i_limit), i_limit)  # np.clip, without its wrapper
        unsaturated = feedforward + _mapped(feedback_map, p_term + i_candidate + d_term)
        max_step = c.slew_rate_limit * dt
        command = limited(unsaturated, c.output_limit, max_step, self._prev_command)
        saturated = np.abs(command - unsaturated) > 1e-12
        if c.anti_windup is AntiWindup.BACK_CALCULATION:
            i_candidate = i_candidate + (command - unsaturated) * dt / c.back_calculation_time_s
            command = None
        elif c.anti_windup is AntiWindup.CONDITIONAL_INTEGRATION and np.count_nonzero(saturated):
            # Integrate only where it pulls the output back inside the limit.
            pushing_out = saturated & (np.sign(error) == np.sign(unsaturated))
            i_candidate = np.where(pushing_out, self._i_term, i_candidate)
            command = None
        self._i_term = np.asarray(i_candidate, dtype=float)

        if command is None:
            feedback = _mapped(feedback_map, p_term + self._i_term + d_term)
            command = limited(feedforward + feedback, c.output_limit, max_step, self._prev_command)
        if np.count_nonzero(np.isfinite(command)) != command.size:
            command = np.where(np.isfinite(command), command, 0.0)
        self._prev_command = command
        return PidTerms(command, p_term, self._i_term, d_term, feedforward, saturated)  # (I: replaced, never written)


def limited(command: np.ndarray, limit: np.ndarray, max_step: float, previous: np.ndarray | None) -> np.ndarray:
    """``command`` within ``±limit`` and, if ``max_step`` > 0, within ``max_step`` of ``previous`` (None: none)."""
    out = np.minimum(np.maximum(command, -limit), limit)  # np.clip, without its wrapper
    if max_step > 0 and previous is not None:
        out = np.minimum(np.maximum(out, previous - max_step), previous + max_step)
    return out


def _mapped(feedback_map: np.ndarray | None, feedback: np.ndarray) -> np.ndarray:
    """The feedback torques through ``feedback_map`` (as they are without one)."""
    return feedback if feedback_map is None else feedback_map @ feedback


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
    """``M(q)·diag(M(q))⁻¹``: the torques that give each joint the acceleration its own gains ask for on a chain
    whose inertias couple (computed-torque feedback). None when off, on one joint or without the arm model."""
    if not decoupling or dynamics is None or np.size(position) < 2:
        return None
    mass = dynamics.mass_matrix(position)
    return mass / mass.diagonal()  # (each column by its joint's own inertia: the diagonal broadcast along rows)


#: the most a rated payload raises a joint's LQR design inertia (and gains) over the arm's own: the unloaded loop's
#: bandwidth at most doubles (the Panda at 100 Hz: 4× leaves every joint 1 period of delay margin, 4.25× not;
#: the PID's gains, as given, stay on the arm's own: its default is already at 1 period)
PAYLOAD_INERTIA_RATIO = 4.0


def design_inertia(
    dynamics: ArmDynamics, joint_count: int, design_position: tuple[float, ...] | None = None, payload_kg: float = 0.0
) -> np.ndarray:
    """Each joint's own inertia (M's diagonal, kg·m²) at the design pose (None: every joint at 0, or the nearest
    end of its range) on the nominal model: each joint's gains are designed for it. With ``payload_kg`` (a rated
    payload the model lacks) at its worst place within reach, at most PAYLOAD_INERTIA_RATIO × the arm's own."""
    model = getattr(dynamics, "model", None)  # a MuJoCo model knows the joints' ranges
    pose = np.zeros(joint_count) if design_position is None else np.asarray(design_position, dtype=float)
    if design_position is None and model is not None:
        pose = np.clip(pose, *position_ranges(model)[:joint_count].T)
    # The nominal model's (the armature learnt at run time taken away): a redesign never compounds with the
    # scaling the inertia adaptation puts on the gains.
    inertia = np.diag(dynamics.mass_matrix(pose)) - getattr(dynamics, "learnt_armature", 0.0)
    if payload_kg > 0 and model is not None:
        inertia = np.minimum(inertia + payload.inertia_bound(model, payload_kg, pose), PAYLOAD_INERTIA_RATIO * inertia)
    return inertia


def inertia_scaled(
    pid: PidConfig,
    dynamics: ArmDynamics | None,
    joint_count: int,
    reference_inertia: float,
    design_position: tuple[float, ...] | None,
    scaled: tuple[str, ...],
) -> PidConfig:
    """``pid`` with the gains named in ``scaled`` (one value each, for a joint of ``reference_inertia`` kg·m²)
    times each joint's design inertia over it: the reference joint's closed loop on every joint."""
    if not scaled or reference_inertia <= 0 or dynamics is None:
        return pid
    ratio = design_inertia(dynamics, joint_count, design_position) / reference_inertia
    return replace(pid, **{name: getattr(pid, name) * ratio for name in scaled})


# A tick later than this many periods after the last one is integrated over this many.
MAX_STEP_PERIODS = 5


class BuiltinLaw(ControlLaw):
    """Model feedforward less the observer's torque, plus the PID's feedback. Params: ``pid`` (a
    :class:`PidConfig`), ``feedforward`` (a FeedforwardMode), ``feedback_decoupling``, ``lqr_q``,
    ``lqr_r``, ``reference_inertia``, ``design_position``, ``scaled_gains``, ``rated_payload_kg`` (the LQR's)."""

    kind: ClassVar[str] = ""

    def __init__(self, arm: Arm, period_s: float, params: Mapping[str, Any]) -> None:
        super().__init__(arm, period_s, params)
        self.pid = Pid(self.gains())
        self._terms: PidTerms | None = None
        self._last_s: float | None = None

    def gains(self) -> PidConfig:
        """The PID settings this law runs with (the LQR's: designed; one value each: scaled per joint)."""
        p, arm = self.params, self.arm
        inertia, pose = p.get("reference_inertia", 0.0), p.get("design_position")
        return inertia_scaled(p["pid"], arm.model, arm.joint_count, inertia, pose, p.get("scaled_gains", ()))

    def set_params(self, params: Mapping[str, Any]) -> None:
        """New gains and options, bumpless (the PID keeps its I term in N·m)."""
        self.params = dict(params)
        self.pid.set_config(self.gains())

    def reset(self, state: State | None = None) -> None:
        self.pid.reset()
        self._last_s = None

    def update(self, time_s: float, state: State, reference: Reference) -> np.ndarray:
        """Feedforward for ``reference.ahead`` less ``state.disturbance``, plus the PID's feedback over the time
        since the last update (at most MAX_STEP_PERIODS)."""
        dt_s = self.period_s
        if self._last_s is not None and time_s > self._last_s:
            dt_s = min(time_s - self._last_s, MAX_STEP_PERIODS * self.period_s)
        self._last_s = time_s
        model = self.arm.model
        ahead = reference.feedforward or reference[:3]  # (Reference.ahead, without a property's call)
        feedforward = feedforward_torque(self.params["feedforward"], model, *ahead) - state.disturbance
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
        return {} if self._terms is None else dict(vars(self._terms))  # command, p, i, d, feedforward, saturated

    @property
    def last_terms(self) -> PidTerms | None:
        """The last update's :class:`PidTerms` as the PID made them (None before any): what :meth:`terms` names,
        without a dict made of them each tick."""
        return self._terms

    def describe(self, observer: str = "") -> str:
        """One line: the law, the gains in force, the torque limit, the feedforward and ``observer`` (a clause on
        the disturbance observer); under LQR, that the kp/ki/kd parameters are unused."""
        gains, p = self.pid.config, self.params
        units = getattr(self.arm.model, "joint_units", None) or ["rad"] * self.arm.joint_count

        def said(values: Any, revolute: str, prismatic: str) -> str:  # N·m and rad, or N and m
            return in_units(values, [revolute if unit == "rad" else prismatic for unit in units], ".3g")

        in_force = (
            f"Kp={said(gains.kp, 'N·m/rad', 'N/m')}, Ki={said(gains.ki, 'N·m/(rad·s)', 'N/(m·s)')}, "
            f"Kd={said(gains.kd, 'N·m·s/rad', 'N·s/m')}, D on {gains.derivative_source.value}, "
            f"|torque| <= {said(gains.output_limit, 'N·m', 'N')}, feedforward {p['feedforward'].value}{observer}"
        )
        if self.kind == "lqr":
            load = f", for a {p['rated_payload_kg']:g} kg payload" if p.get("rated_payload_kg") else ""
            return (
                f"LQR (q={in_units(p['lqr_q'], spec='.3g')}, r={_weights(p['lqr_r'])}, designed at "
                f"{1.0 / self.period_s:g} Hz{load}): {in_force}; the kp/ki/kd parameters are unused"
            )
        scaled = "/".join(p.get("scaled_gains", ()))  # one value each, for reference_inertia
        return f"PID{f' ({scaled} × each joint inertia / reference_inertia)' if scaled else ''}: {in_force}"


def _weights(lqr_r: float | Sequence[float]) -> str:
    return f"{lqr_r:g}" if np.ndim(lqr_r) == 0 else "[" + ", ".join(f"{r:.3g}" for r in lqr_r) + "]"


class PidLaw(BuiltinLaw):
    """PID with the node's kp, ki, kd."""

    kind = "pid"
