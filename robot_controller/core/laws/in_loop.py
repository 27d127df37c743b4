"""A law as the controller runs it, whichever it is: built with the arm, the control period and
its parameters, called with ``update(time, state, reference)``, its torque held to the torque
limit and slew rate, its terms gathered for ``/controller/state``. A user's law is called through
:class:`ContainedLaw` (its faults become a :class:`LawFault`); a built-in one is trusted."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.laws import parameters, registry
from robot_controller.core.laws.builtin import BuiltinLaw
from robot_controller.core.laws.containment import ContainedLaw, LawFault
from robot_controller.core.laws.interface import Arm, ControlLaw, Reference, State
from robot_controller.core.laws.pid import PidTerms


def arm_for(dynamics, joint_count: int, torque_limit: np.ndarray) -> Arm:
    """What a law is told about the arm: the controller's model of it (None: no model) and its limits."""
    limits = np.tile([-np.inf, np.inf], (joint_count, 1))
    model = getattr(dynamics, "model", None)  # a MuJoCo model knows the joints' ranges
    if model is not None:
        limited = model.jnt_limited[:joint_count].astype(bool)
        limits[limited] = model.jnt_range[:joint_count][limited]
    names = tuple(dynamics.joint_names) if dynamics is not None else tuple(f"joint {j + 1}" for j in range(joint_count))
    return Arm(dynamics, names, np.array(torque_limit, dtype=float), limits)


class LawInLoop:
    """``law`` called directly (a built-in) or through ``contained`` (a user's law)."""

    def __init__(
        self, law: ControlLaw, joint_count: int, slew_rate_limit: float, contained: ContainedLaw | None = None
    ) -> None:
        self.law = law
        self.contained = contained
        self.joint_count = joint_count
        self.output_limit = law.arm.torque_limit  #: N·m per joint
        self.slew_rate_limit = slew_rate_limit  #: N·m/s (0: none)
        self.extra_terms = tuple(getattr(type(law), "state_terms", ()) or ()) if contained is not None else ()
        self.params: Mapping[str, Any] = {}  #: a user's law's parameter values, as last given
        self._previous_command: np.ndarray | None = None
        self._last_s: float | None = None

    @classmethod
    def builtin(cls, kind: str, arm: Arm, period_s: float, params: Mapping[str, Any]) -> LawInLoop:
        return cls(BuiltinLaw.of_kind(kind, arm, period_s, params), arm.joint_count, params["pid"].slew_rate_limit)

    @classmethod
    def plugin(
        cls, spec: str, arm: Arm, period_s: float, given: Mapping[str, Any], clock: Callable[[], float] | None = None
    ) -> LawInLoop:
        """The law ``spec`` names, built with the values ``given`` for its parameters and contained (its
        time checked on ``clock``, seconds of wall time; None: not checked); ``ConfigError`` in one line
        if it cannot be built. Its limits: :meth:`set_limits`."""
        if arm.model is None:
            raise ConfigError("controller_type: a law of one's own needs the arm model (urdf_path)")
        law_class = registry.resolve(spec)
        values = parameters.values(law_class, given, arm.joint_count)
        try:
            law = law_class(arm, period_s, values)
        except ConfigError:
            raise
        except Exception as exc:
            raise ConfigError(f"controller_type: {spec} failed to start: {type(exc).__name__}: {exc}") from exc
        in_loop = cls(law, arm.joint_count, 0.0, ContainedLaw(law, spec, arm.joint_count, 0.005, clock))
        in_loop.contained.joint_names = arm.joint_names
        in_loop.params = values
        return in_loop

    def set_limits(
        self,
        output_limit: np.ndarray,
        slew_rate_limit: float,
        budget_s: float,
        error_max_rad: float,
        stop_deceleration_rad_s2: float,
    ) -> None:
        """What a user's law is held to: the torque limit (N·m per joint), the slew rate (N·m/s, 0: none),
        its time per update (s), how far it may let the arm run away (rad, 0: no check) and the
        deceleration of the stop that check counts with (rad/s²)."""
        self.output_limit, self.slew_rate_limit = np.array(output_limit, dtype=float), slew_rate_limit
        c = self.contained
        c.budget_s, c.error_max_rad, c.stop_deceleration_rad_s2 = budget_s, error_max_rad, stop_deceleration_rad_s2

    @property
    def fault(self) -> LawFault | None:
        return None if self.contained is None else self.contained.fault

    def set_params(self, params: Mapping[str, Any]) -> None:
        """New parameter values (a user's law: checked against its declarations first)."""
        if self.contained is None:
            self.law.set_params(params)
            self.slew_rate_limit = params["pid"].slew_rate_limit
            return
        self.params = parameters.values(type(self.law), params, self.joint_count)
        self.contained.set_params(0.0, self.params)

    def reset(self, now_s: float, state: State) -> None:
        self._previous_command, self._last_s = None, None
        if self.contained is None:
            self.law.reset(state)
        else:
            self.contained.reset(now_s, state)

    def update(self, now_s: float, state: State, reference: Reference) -> tuple[PidTerms, dict] | LawFault:
        """The law's command for the tick within the limits, with its terms (and a user's law's extra
        terms by name); or the fault it made. A built-in law limits its own command (its anti-windup
        needs to); a user's law is held to the torque limit and slew rate here."""
        if self.contained is None:
            self.law.update(now_s, state, reference)
            t = self.law.terms()
            return PidTerms(t["command"], t["p"], t["i"], t["d"], t["feedforward"], t["saturated"]), {}
        torque = self.contained.update(now_s, state, reference)
        if isinstance(torque, LawFault):
            return torque
        dt_s = self.law.period_s if self._last_s is None or now_s <= self._last_s else now_s - self._last_s
        self._last_s = now_s
        command = np.minimum(np.maximum(torque, -self.output_limit), self.output_limit)  # np.clip, without its wrapper
        if self.slew_rate_limit > 0 and self._previous_command is not None:
            step = self.slew_rate_limit * dt_s
            command = np.minimum(np.maximum(command, self._previous_command - step), self._previous_command + step)
        self._previous_command = command
        runaway = self.contained.check_runaway(now_s, state, reference, command - self.law.arm.gravity(state.position))
        if runaway is not None:
            return runaway
        reported = self._checked_terms()
        zeros = np.zeros(self.joint_count)
        terms = PidTerms(
            command,
            reported.get("p", zeros),
            reported.get("i", zeros),
            reported.get("d", zeros),
            reported.get("feedforward", zeros),
            np.abs(command - torque) > 1e-12,
        )
        return terms, {name: reported.get(name, zeros) for name in self.extra_terms}

    def _checked_terms(self) -> dict[str, np.ndarray]:
        """A user's law's terms, each one finite number per joint (others are not reported)."""
        out = {}
        for name, value in self.contained.terms().items():
            try:
                array = np.broadcast_to(np.asarray(value, dtype=float), (self.joint_count,))
            except (TypeError, ValueError):
                continue
            out[name] = np.where(np.isfinite(array), array, 0.0)
        return out

    def describe(self) -> str:
        """The law's name and parameter values, e.g. ``own.py:Law (gain=2.5)``."""
        shown = ", ".join(f"{k}={_show(v)}" for k, v in self.params.items())
        return f"{self.contained.name}" + (f" ({shown})" if shown else "")


def _show(value) -> str:
    if isinstance(value, np.ndarray):
        return "[" + ", ".join(f"{v:.3g}" for v in value) + "]"
    return f"{value:.3g}" if isinstance(value, float) else repr(value)
