"""A plugin law inside the controller: built from ``controller_type`` with the
arm and its parameter values, called through :class:`ContainedLaw`, its
torque held to the torque limit and slew rate like the built-in law's, its
terms gathered for ``/controller/state``."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from robot_controller.core.arrays import clip, within
from robot_controller.core.controller.config import ControllerConfig
from robot_controller.core.controller.reference_at_tick import Reference as TickReference
from robot_controller.core.errors import ConfigError
from robot_controller.core.laws import parameters, registry
from robot_controller.core.laws.containment import ContainedLaw, LawFault
from robot_controller.core.laws.interface import Arm, Reference, State
from robot_controller.core.laws.pid import PidTerms

STANDARD_TERMS = ("p", "i", "d", "feedforward")


def arm_for(dynamics, joint_count: int, torque_limit: np.ndarray) -> Arm:
    """What a law is told about the arm: the controller's model of it and its limits."""
    if dynamics is None:
        raise ConfigError("controller_type: a law of one's own needs the arm model (urdf_path)")
    limits = np.tile([-np.inf, np.inf], (joint_count, 1))
    model = getattr(dynamics, "model", None)  # a MuJoCo model knows the joints' ranges
    if model is not None:
        limited = model.jnt_limited[:joint_count].astype(bool)
        limits[limited] = model.jnt_range[:joint_count][limited]
    return Arm(dynamics, tuple(dynamics.joint_names), np.array(torque_limit, dtype=float), limits)


class PluginLaw:
    def __init__(
        self, contained: ContainedLaw, config: ControllerConfig, law_class: type, joint_count: int, arm: Arm
    ) -> None:
        self.contained = contained
        self.arm = arm  #: the arm the law was given: its gravity, for the runaway check
        self.config = config
        self.law_class = law_class
        self.joint_count = joint_count
        self.extra_terms = tuple(getattr(law_class, "state_terms", ()) or ())
        self._previous_command: np.ndarray | None = None

    @classmethod
    def build(
        cls, config: ControllerConfig, dynamics, joint_count: int, clock: Callable[[], float] | None = None
    ) -> PluginLaw:
        """The law ``config.controller_type`` names, built; ``ConfigError`` in one line if it cannot be."""
        law_class = registry.resolve(config.controller_type)
        values = parameters.values(law_class, config.law_parameters, joint_count)
        arm = arm_for(dynamics, joint_count, config.pid.output_limit)
        try:
            law = law_class(arm, config.control_period_s, values)
        except ConfigError:
            raise
        except Exception as exc:
            raise ConfigError(
                f"controller_type: {config.controller_type} failed to start: {type(exc).__name__}: {exc}"
            ) from exc
        contained = ContainedLaw(
            law,
            config.controller_type,
            joint_count,
            config.law_budget_s,
            clock,
            config.law_error_max_rad,
            config.stop_deceleration,
            tuple(getattr(dynamics, "joint_names", ()) or ()),
        )
        return cls(contained, config, law_class, joint_count, arm)

    @property
    def fault(self) -> LawFault | None:
        return self.contained.fault

    def describe(self) -> str:
        values = parameters.values(self.law_class, self.config.law_parameters, self.joint_count)
        shown = ", ".join(f"{k}={_show(v)}" for k, v in values.items())
        return f"{self.config.controller_type}" + (f" ({shown})" if shown else "")

    def set_params(self, config: ControllerConfig) -> None:
        """New values for the law's parameters, checked first (a bad one is refused with its reason)."""
        if config.law_parameters != self.config.law_parameters:
            values = parameters.values(self.law_class, config.law_parameters, self.joint_count)
            self.contained.set_params(0.0, values)
        self.contained.budget_s, self.contained.error_max_rad = config.law_budget_s, config.law_error_max_rad
        self.contained.stop_deceleration_rad_s2 = config.stop_deceleration
        self.config = config

    def reset(
        self,
        now_s: float,
        position: np.ndarray,
        velocity: np.ndarray,
        reading: tuple[np.ndarray, np.ndarray] | None,
    ) -> None:
        measured = reading if reading is not None else (position, velocity)
        self._previous_command = None
        self.contained.reset(now_s, State(position, velocity, *measured, np.zeros(self.joint_count)))

    def step(
        self,
        now_s: float,
        dt_s: float,
        position: np.ndarray,
        velocity: np.ndarray,
        reading: tuple[np.ndarray, np.ndarray] | None,
        reference: TickReference,
        disturbance: np.ndarray | None,
    ) -> tuple[PidTerms, dict[str, np.ndarray]] | LawFault:
        """The law's command for the tick within the limits, with its terms; or its fault."""
        zeros = np.zeros(self.joint_count)
        measured = reading if reading is not None else (position, velocity)
        state = State(position, velocity, measured[0], measured[1], zeros if disturbance is None else disturbance)
        torque = self.contained.update(
            now_s, state, Reference(reference.position, reference.velocity, reference.acceleration)
        )
        if isinstance(torque, LawFault):
            return torque
        command = within(torque, self.config.pid.output_limit)
        slew = self.config.pid.slew_rate_limit
        if slew > 0 and self._previous_command is not None:
            step = slew * dt_s
            command = clip(command, self._previous_command - step, self._previous_command + step)
        self._previous_command = command
        runaway = self.contained.check_runaway(now_s, state, reference, command - self.arm.gravity(position))
        if runaway is not None:
            return runaway
        reported = self._terms()
        terms = PidTerms(
            command,
            reported.get("p", zeros),
            reported.get("i", zeros),
            reported.get("d", zeros),
            reported.get("feedforward", zeros),
            np.abs(command - torque) > 1e-12,
        )
        return terms, {name: reported.get(name, zeros) for name in self.extra_terms}

    def _terms(self) -> dict[str, np.ndarray]:
        out = {}
        for name, value in self.contained.terms().items():
            try:
                array = np.broadcast_to(np.asarray(value, dtype=float), (self.joint_count,))
            except (TypeError, ValueError):
                continue  # a term that is not one number per joint is not reported
            out[name] = np.where(np.isfinite(array), array, 0.0)
        return out


def _show(value) -> str:
    if isinstance(value, np.ndarray):
        return "[" + ", ".join(f"{v:.3g}" for v in value) + "]"
    return f"{value:.3g}" if isinstance(value, float) else repr(value)
