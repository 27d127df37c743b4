"""A law the framework does not trust: every call to it is checked, and the first thing it
gets wrong becomes a :class:`LawFault` instead of a torque: it raises, returns anything but one
finite number per joint, takes longer than its budget on OVERRUN_TICKS ticks running (one long
call alone is the machine's doing, a slow law is slow on every tick; measured on ``clock``,
seconds of wall time, or not at all without one), or lets the arm run away from the reference
(``error_max_rad``). The controller answers a fault with a controlled stop on its built-in law;
the law is never called again."""

from __future__ import annotations

import traceback
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from robot_controller.core.laws.interface import Reference, State

# Consecutive updates over the budget that make a fault.
OVERRUN_TICKS = 3
# rad/s: slower than this the arm is not running away, whatever its distance.
RUNAWAY_MIN_SPEED_RAD_S = 0.1


@dataclass(frozen=True)
class LawFault:
    """What a law did wrong, and when."""

    law: str  #: the law as ``controller_type`` names it
    what: str  #: e.g. "raised ZeroDivisionError: division by zero"
    time_s: float  #: the tick it happened on, s
    traceback: str = ""  #: the law's traceback when it raised

    def line(self) -> str:
        return f"control law {self.law} {self.what} at t = {self.time_s:.3f} s"


class ContainedLaw:
    """Calls a law's methods and checks what comes back."""

    def __init__(
        self,
        law: Any,
        name: str,
        joint_count: int,
        budget_s: float,
        clock: Callable[[], float] | None = None,
        error_max_rad: float = 0.0,
        stop_deceleration_rad_s2: float = 20.0,
        joint_names: tuple[str, ...] = (),
    ) -> None:
        self.law = law
        self.name = name
        self.joint_count = joint_count
        self.budget_s = budget_s
        self.error_max_rad = error_max_rad  #: how far the arm may be from the reference (0: no check)
        self.stop_deceleration_rad_s2 = stop_deceleration_rad_s2  #: the controlled stop's, for the way still to go
        self.joint_names = joint_names  #: for the fault's line (none: numbered)
        self.clock = clock
        self.fault: LawFault | None = None
        self.overruns_s: list[float] = []  #: the durations of the updates over budget in a row, s

    def reset(self, time_s: float, state: State) -> LawFault | None:
        reset = getattr(self.law, "reset", None)
        if reset is None:
            return None
        return self._call(time_s, "reset", lambda: reset(state)) if self.fault is None else self.fault

    def set_params(self, time_s: float, params: Mapping[str, Any]) -> LawFault | None:
        setter = getattr(self.law, "set_params", None)
        if setter is None:
            self.law.params = dict(params)
            return None
        return self._call(time_s, "set_params", lambda: setter(params))

    def update(self, time_s: float, state: State, reference: Reference) -> np.ndarray | LawFault:
        """The law's torque per joint (float64, finite), or the fault it made."""
        if self.fault is not None:
            return self.fault
        returned = self._call(time_s, "update", lambda: self.law.update(time_s, state, reference))
        if isinstance(returned, LawFault):
            return returned
        try:
            torque = np.asarray(returned, dtype=float)
        except (TypeError, ValueError):
            return self._faulted(time_s, f"returned {type(returned).__name__}, not one torque per joint")
        if torque.ndim == 0 and self.joint_count == 1:
            torque = torque.reshape(1)
        if torque.shape != (self.joint_count,):
            return self._faulted(
                time_s, f"returned a torque of shape {torque.shape}, expected ({self.joint_count},): one per joint"
            )
        if not np.all(np.isfinite(torque)):
            return self._faulted(time_s, f"returned a non-finite torque {torque.tolist()}")
        return torque

    def check_runaway(
        self, time_s: float, state: State, reference: Reference, net_torque: np.ndarray
    ) -> LawFault | None:
        """A fault once the arm moves away from the reference, further than ``error_max_rad`` counting
        the way it would still go before a stop at ``stop_deceleration_rad_s2`` turned it, while the
        law's ``net_torque`` (its command less gravity's, N·m) pushes it on. A law braking an
        overshoot, or bringing the arm back to a reference that jumped, is doing its work."""
        if self.error_max_rad <= 0 or self.fault is not None:
            return self.fault
        error = np.asarray(state.position, dtype=float) - np.asarray(reference.position, dtype=float)
        error_rate = np.asarray(state.velocity, dtype=float) - np.asarray(reference.velocity, dtype=float)
        if not (np.all(np.isfinite(error)) and np.all(np.isfinite(error_rate)) and np.all(np.isfinite(net_torque))):
            return None  # not the law's doing: the readings and the reference have guards of their own
        running = (error * error_rate > 0) & (np.abs(error_rate) > RUNAWAY_MIN_SPEED_RAD_S) & (net_torque * error > 0)
        projected = np.where(running, np.abs(error) + error_rate**2 / (2 * self.stop_deceleration_rad_s2), 0.0)
        joint = int(np.argmax(projected))
        if projected[joint] <= self.error_max_rad:
            return None
        name = self.joint_names[joint] if joint < len(self.joint_names) else f"joint {joint + 1}"
        return self._faulted(
            time_s,
            f"let the arm run away from its reference on {name}: {error[joint]:+.3f} rad off and "
            f"{abs(error_rate[joint]):.2f} rad/s away, pushed on ({net_torque[joint]:+.2f} N·m beyond gravity), "
            f"{projected[joint]:.3f} rad with a stop at {self.stop_deceleration_rad_s2:g} rad/s² "
            f"(law_error_max_rad {self.error_max_rad:g})",
        )

    def terms(self) -> Mapping[str, np.ndarray]:
        """The law's reported terms, or none if reporting them fails (never a reason to stop)."""
        terms = getattr(self.law, "terms", None)
        if terms is None or self.fault is not None:
            return {}
        try:
            return dict(terms())
        except Exception:
            return {}

    def _call(self, time_s: float, method: str, call: Callable[[], Any]) -> Any:
        timed = self.clock is not None and method == "update"
        started = self.clock() if timed else 0.0
        try:
            value = call()
        except Exception as exc:
            return self._faulted(
                time_s,
                f"raised {type(exc).__name__}: {exc}" + ("" if method == "update" else f" in {method}()"),
                traceback.format_exc(),
            )
        if timed:
            duration_s = self.clock() - started
            self.overruns_s = self.overruns_s + [duration_s] if duration_s > self.budget_s else []
            if len(self.overruns_s) >= OVERRUN_TICKS:
                took = ", ".join(f"{d * 1e3:.1f}" for d in self.overruns_s)
                return self._faulted(
                    time_s,
                    f"took {took} ms in update() on {OVERRUN_TICKS} ticks running, over its budget of "
                    f"{self.budget_s * 1e3:g} ms (law_budget_s)",
                )
        return value

    def _faulted(self, time_s: float, what: str, trace: str = "") -> LawFault:
        self.fault = LawFault(self.name, what, time_s, trace)
        return self.fault
