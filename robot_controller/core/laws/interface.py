"""What a control law is: the small interface every law implements, the built-in PID and LQR included. The
framework builds a law once with the arm, the control period and its parameters, calls :meth:`ControlLaw.reset`
whenever the loop (re)starts from a measurement, and :meth:`ControlLaw.update` once per tick for a torque per
joint; everything around that (timing, the watchdog, the state estimate, limits, stops, logging) is the
framework's. Units: rad, rad/s, rad/s², N·m, s.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar, NamedTuple, Protocol

import numpy as np


@dataclass(frozen=True)
class Parameter:
    """One parameter a law declares: the ``pid_controller`` parameter ``law.NAME`` (``robot-controller params``
    lists it; ``--config`` and ``param set`` set it, checked against this range). ``default``: a number, a bool, a
    string, or a list of numbers (one per joint, or one for all when ``per_joint``). ``gain``: ``tune`` searches it
    (numbers only; needs ``minimum`` and ``maximum``)."""

    name: str
    default: Any
    description: str = ""
    minimum: float | None = None
    maximum: float | None = None
    per_joint: bool = False
    gain: bool = False


class ArmModel(Protocol):
    """The arm as a law sees it (the controller's model, from its URDF and any ``model_*``), in the URDF's order."""

    joint_names: list[str]

    def mass_matrix(self, position: np.ndarray) -> np.ndarray:
        """M(q), kg·m² (n × n)."""
        ...

    def gravity(self, position: np.ndarray) -> np.ndarray:
        """The torque that holds the arm still at ``position``, N·m."""
        ...

    def torque(self, position: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
        """Inverse dynamics: the torque that gives ``acceleration`` at ``(position, velocity)``, N·m."""
        ...


@dataclass(frozen=True)
class Arm:
    """What a law's constructor receives about the arm: its ``model`` and its limits."""

    model: ArmModel
    joint_names: tuple[str, ...]
    torque_limit: np.ndarray  #: N·m per joint; the framework clips every command to it
    position_limits: np.ndarray  #: rad, (n, 2): lower, upper (±inf for a continuous joint)

    @property
    def joint_count(self) -> int:
        return len(self.joint_names)

    def mass_matrix(self, position: np.ndarray) -> np.ndarray:
        return self.model.mass_matrix(position)

    def gravity(self, position: np.ndarray) -> np.ndarray:
        return self.model.gravity(position)

    def inverse_dynamics(self, position: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray) -> np.ndarray:
        return self.model.torque(position, velocity, acceleration)


class State(NamedTuple):
    """The arm at the tick, per joint: the framework's estimate and the reading it came from. (Named tuples, this
    and ``Reference``: the controller builds one of each every tick, and a tuple is built fastest.)"""

    position: np.ndarray  #: rad, estimated at the tick
    velocity: np.ndarray  #: rad/s, estimated at the tick
    measured_position: np.ndarray  #: rad, the latest reading as the sensor sent it
    measured_velocity: np.ndarray  #: rad/s, the latest reading
    #: N·m, the disturbance observer's estimate of an external torque (zeros without it);
    #: a law that subtracts it gets the observer's rejection for free
    disturbance: np.ndarray


class Reference(NamedTuple):
    """Where the arm should be at the tick, per joint: the planner's, or the framework's own during a hold, a stop
    or the blend back onto the trajectory; a law tracks it the same way either way."""

    position: np.ndarray  #: rad
    velocity: np.ndarray  #: rad/s
    acceleration: np.ndarray  #: rad/s²
    #: ``(position, velocity, acceleration)`` at the middle of the control period the command is held
    #: over, where a model's torque equals its average over the period; None: the reference itself
    feedforward: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    @property
    def ahead(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The reference a feedforward torque is for: :attr:`feedforward`, or the reference itself."""
        return self.feedforward if self.feedforward is not None else (self.position, self.velocity, self.acceleration)


class ControlLaw:
    """Subclass this, override :meth:`update` (and :meth:`reset` if the law keeps state), and name it in
    ``controller_type`` as ``path/to/file.py:Class``, ``package.module:Class`` or an installed plugin's name.
    ``parameters``: what it declares (values in ``self.params`` by name); ``state_terms``: extra per-joint terms
    it reports through :meth:`terms` (``p``, ``i``, ``d`` and ``feedforward`` fill the standard blocks).
    """

    parameters: ClassVar[tuple[Parameter, ...]] = ()
    state_terms: ClassVar[tuple[str, ...]] = ()

    def __init__(self, arm: Arm, period_s: float, params: Mapping[str, Any]) -> None:
        self.arm = arm
        self.period_s = period_s
        self.params = dict(params)

    def reset(self, state: State) -> None:
        """The loop starts (again) from ``state``: forget integrators and history."""

    def update(self, time_s: float, state: State, reference: Reference) -> np.ndarray:
        """The torque per joint (N·m) for the tick at ``time_s``."""
        raise NotImplementedError(f"{type(self).__name__}.update")

    def set_params(self, params: Mapping[str, Any]) -> None:
        """New parameter values while running (already checked); override to make the change bumpless."""
        self.params = dict(params)

    def terms(self) -> Mapping[str, np.ndarray]:
        """The last update's parts for the controller's state (N·m per joint)."""
        return {}
