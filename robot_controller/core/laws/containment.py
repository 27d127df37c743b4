"""A user's law, contained: a :class:`ControlLaw` itself, so the controller runs it as the built-in law, each call
to the user's law checked, its torque held to the torque limit and the slew rate. The first thing it gets wrong
becomes its ``fault`` (a :class:`LawFault`) instead of a torque: it raises, returns anything but one finite number
per joint, takes longer than its budget on OVERRUN_TICKS ticks running (one long call alone is the machine's doing;
measured on ``clock`` on the law's thread less the time it waited for a CPU), is still running when the controller
stops waiting for it (timed, its calls run on a :class:`LawWorker`), or lets the arm run away from the reference
(``error_max_rad``). The controller answers with a controlled stop on its built-in law; the law is never called
again."""

from __future__ import annotations

import ctypes
import queue
import threading
import time
import traceback
import weakref
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.laws.collection_time import collected_s
from robot_controller.core.laws.interface import Arm, ControlLaw, Reference, State
from robot_controller.core.laws.law_parameters import values as parameter_values
from robot_controller.core.laws.pid import limited
from robot_controller.core.laws.registry import resolve

# Consecutive updates over the budget that make a fault.
OVERRUN_TICKS = 3
# rad/s: slower than this the arm is not running away, whatever its distance.
RUNAWAY_MIN_SPEED_RAD_S = 0.1
# s of wall time after which a call the world waits for is blocked: far more than a busy host keeps a thread from a CPU.
BLOCKED_S = 0.5


@dataclass(frozen=True)
class LawFault:
    """What a law did wrong, and when."""

    law: str  #: the law as ``controller_type`` names it
    what: str  #: e.g. "raised ZeroDivisionError: division by zero"
    time_s: float | None  #: the tick it happened on, s (None: before the first)
    traceback: str = ""  #: the law's traceback when it raised

    def line(self) -> str:
        at = "before the first tick" if self.time_s is None else f"at t = {self.time_s:.3f} s"
        return f"control law {self.law} {self.what} {at}"


class _Abandoned(BaseException):
    """Raised in an abandoned call at its next Python instruction, to end it."""


def _outcome(call: Callable[[], Any]) -> tuple[Any, str | None]:
    """``(value, None)``, or ``(exception, traceback)`` when ``call`` raised anything, ``SystemExit`` too."""
    try:
        return call(), None
    except BaseException as exc:  # noqa: BLE001 - whatever a law raises is its fault, never the controller's end
        return exc, traceback.format_exc()


class LawWorker:
    """A thread running a law's calls one at a time, so the controller can stop waiting for one that blocks. An
    abandoned call is asked to end at its next Python instruction; one blocked in C code runs on (a thread cannot be
    killed). The thread ends once the worker is no longer referenced."""

    def __init__(self, name: str) -> None:
        self._calls: queue.SimpleQueue = queue.SimpleQueue()
        self._done = threading.Event()
        self._outcome: list[tuple[Any, str | None]] = [(None, None)]  # shared with the thread, which holds no self
        self._thread = threading.Thread(
            target=_serve, args=(self._calls, self._done, self._outcome), name=f"law {name}", daemon=True
        )
        self._thread.start()
        weakref.finalize(self, self._calls.put, None)

    def run(
        self, call: Callable[[], Any], timeout_s: float, cpu_limit_s: float | None = None
    ) -> tuple[Any, str | None] | None:
        """:func:`_outcome` of ``call``, or None (abandoned) if it is still running after ``timeout_s`` of wall time
        or ``cpu_limit_s`` of its thread's CPU time (a call kept from a CPU uses none; one that loops uses it all)."""
        self._done.clear()
        deadline_s = time.monotonic() + timeout_s
        started_cpu_s = 0.0 if cpu_limit_s is None else self.cpu_s()
        self._calls.put(call)
        # Looked at every ``cpu_limit_s``: a call within it is never looked at.
        while not (done := self._done.wait(max(0.0, min(cpu_limit_s or timeout_s, deadline_s - time.monotonic())))):
            if time.monotonic() >= deadline_s or self.cpu_s() - started_cpu_s >= (cpu_limit_s or float("inf")):
                break
        if done:
            outcome, self._outcome[0] = self._outcome[0], (None, None)  # the thread keeps nothing of the law's
            return outcome
        self._calls.put(None)  # the thread ends once the call does
        ctypes.pythonapi.PyThreadState_SetAsyncExc(ctypes.c_ulong(self._thread.ident), ctypes.py_object(_Abandoned))
        return None

    def cpu_s(self) -> float:
        """The CPU time the worker's thread has used, s (its schedstat; 0 where that cannot be read), less its garbage
        collections' (:mod:`.collection_time`)."""
        try:
            with open(f"/proc/self/task/{self._thread.native_id}/schedstat", "rb") as f:
                return int(f.read().split()[0]) * 1e-9 - collected_s(self._thread.ident)
        except (OSError, IndexError, ValueError):
            return 0.0


def _serve(calls: queue.SimpleQueue, done: threading.Event, outcome: list) -> None:
    """A :class:`LawWorker`'s thread: each call's outcome, until a None."""
    try:
        while (call := calls.get()) is not None:
            outcome[0] = _outcome(call)
            call = None  # nor the call (it holds the law): the worker, once unreferenced, ends this thread
            done.set()
    except _Abandoned:
        pass  # it arrived between calls


class ContainedLaw(ControlLaw):
    """The user's law ``law``, named ``name`` as ``controller_type`` names it, built with ``arm``,
    ``period_s`` and ``params``; what it is held to: :meth:`set_limits`."""

    def __init__(
        self,
        law: Any,
        name: str,
        arm: Arm,
        period_s: float,
        params: Mapping[str, Any],
        clock: Callable[[], float] | None = None,
        budget_s: float = 0.005,
        run_wait: Callable[[], float] | None = None,
        abandon_s: float | None = None,
    ) -> None:
        super().__init__(arm, period_s, params)
        self.law = law
        self.name = name
        self.joint_count = arm.joint_count
        self.joint_names = arm.joint_names  #: for the fault's line
        self.clock = clock
        self.budget_s = budget_s  #: s per update on ``clock`` (its thread's CPU time, or wall time less ``run_wait``)
        self.run_wait = run_wait  #: s the calling thread has waited for a CPU so far (None: not known, not excused)
        self.error_max_rad = 0.0  #: how far the arm may be from the reference (0: no check)
        self.stop_deceleration_rad_s2 = 20.0  #: the controlled stop's, for the way still to go
        self.output_limit = arm.torque_limit  #: N·m per joint
        self.slew_rate_limit = 0.0  #: N·m/s (0: none)
        self.extra_terms = tuple(getattr(type(law), "state_terms", ()) or ())  #: terms beyond the standard blocks
        self.fault: LawFault | None = None
        self.tick_s: float | None = None  #: the latest tick the law was called on, s
        self.worker = LawWorker(name) if clock is not None else None  #: timed, the calls run here
        #: s of wall time a call may run before it is abandoned (None: ``budget_s`` and a control period, as a
        #: loop on the wall clock can wait). A loop the world waits for waits longer, for a law kept from a CPU
        #: is not blocked; one that computes is abandoned once it has used ``budget_s`` and a period of CPU time.
        self.abandon_s = abandon_s
        self.overruns_s: list[float] = []  #: the durations of the updates over budget in a row, s
        self._previous_command: np.ndarray | None = None
        self._last_s: float | None = None
        self._terms: dict[str, np.ndarray] = {}
        self._raw_terms: dict[str, Any] = {}

    @classmethod
    def build(
        cls,
        spec: str,
        arm: Arm,
        period_s: float,
        given: Mapping[str, Any],
        clock: Callable[[], float] | None = None,
        run_wait: Callable[[], float] | None = None,
        abandon_s: float | None = None,
    ) -> ContainedLaw:
        """The law ``spec`` names, built with the values ``given`` and contained; ``ConfigError`` in one line if it
        cannot be built."""
        if arm.model is None:
            raise ConfigError("controller_type: a law of one's own needs the arm model (urdf_path)")
        law_class = resolve(spec)
        values = parameter_values(law_class, given, arm.joint_count)
        try:
            law = law_class(arm, period_s, values)
        except ConfigError:
            raise
        except Exception as exc:
            raise ConfigError(f"controller_type: {spec} failed to start: {type(exc).__name__}: {exc}") from exc
        return cls(law, spec, arm, period_s, values, clock, run_wait=run_wait, abandon_s=abandon_s)

    def set_limits(
        self,
        output_limit: np.ndarray,
        slew_rate_limit: float,
        budget_s: float,
        error_max_rad: float,
        stop_deceleration_rad_s2: float,
    ) -> None:
        """What the law is held to: the torque limit (N·m per joint), slew rate (N·m/s, 0: none), time per update
        (s), runaway distance (rad, 0: no check) and the stop's deceleration that check counts with (rad/s²)."""
        self.output_limit, self.slew_rate_limit = np.array(output_limit, dtype=float), slew_rate_limit
        self.budget_s, self.error_max_rad = budget_s, error_max_rad
        self.stop_deceleration_rad_s2 = stop_deceleration_rad_s2

    def reset(self, state: State, time_s: float | None = None) -> None:
        """The loop starts (again) from ``state`` at the tick ``time_s`` (s; None: the latest)."""
        self._previous_command, self._last_s = None, None
        self.tick_s = self.tick_s if time_s is None else time_s
        reset = getattr(self.law, "reset", None)
        if reset is not None:
            self._call(self.tick_s, "reset", lambda: reset(state))

    def set_params(self, params: Mapping[str, Any]) -> None:
        """New parameter values, checked against the law's declarations first."""
        self.params = parameter_values(type(self.law), params, self.joint_count)
        setter = getattr(self.law, "set_params", None)
        if setter is None:
            self.law.params = dict(self.params)
        else:
            self._call(self.tick_s, "set_params", lambda: setter(self.params))

    def update(self, time_s: float, state: State, reference: Reference) -> np.ndarray:
        """The law's torque within the torque limit and slew rate; zeros once it has made a fault."""
        self.tick_s = time_s
        torque = self._checked_torque(time_s, state, reference)
        if torque is None:
            return np.zeros(self.joint_count)
        dt_s = self.period_s if self._last_s is None or time_s <= self._last_s else time_s - self._last_s
        self._last_s = time_s
        command = limited(torque, self.output_limit, self.slew_rate_limit * dt_s, self._previous_command)
        self._previous_command = command
        if self.error_max_rad > 0 and self.check_runaway(
            time_s, state, reference, command - self.arm.gravity(state.position)
        ):
            return np.zeros(self.joint_count)
        reported = self._reported_terms()
        zeros = np.zeros(self.joint_count)
        self._terms = {name: reported.get(name, zeros) for name in self.extra_terms}
        self._terms.update(
            command=command,
            p=reported.get("p", zeros),
            i=reported.get("i", zeros),
            d=reported.get("d", zeros),
            feedforward=reported.get("feedforward", zeros),
            saturated=np.abs(command - torque) > 1e-12,
        )
        return command

    def terms(self) -> Mapping[str, np.ndarray]:
        """The last update's standard blocks (``command``, ``p``, ``i``, ``d``, ``feedforward``, ``saturated``) and
        the law's :attr:`extra_terms`, per joint."""
        return self._terms

    def describe(self) -> str:
        """The law's name and parameter values, e.g. ``own.py:Law (gain=2.5)``."""
        shown = ", ".join(f"{k}={_show(v)}" for k, v in self.params.items())
        return f"{self.name}" + (f" ({shown})" if shown else "")

    def _checked_torque(self, time_s: float, state: State, reference: Reference) -> np.ndarray | None:
        """The law's torque per joint (float64, finite), or None when it made a fault."""
        returned = self._call(time_s, "update", lambda: (self.law.update(time_s, state, reference), self._law_terms()))
        if isinstance(returned, LawFault):
            return None
        returned, self._raw_terms = returned
        try:
            torque = np.asarray(returned, dtype=float)
        except (TypeError, ValueError):
            self._faulted(time_s, f"returned {type(returned).__name__}, not one torque per joint")
            return None
        if torque.ndim == 0 and self.joint_count == 1:
            torque = torque.reshape(1)
        if torque.shape != (self.joint_count,):
            self._faulted(
                time_s, f"returned a torque of shape {torque.shape}, expected ({self.joint_count},): one per joint"
            )
            return None
        if not np.all(np.isfinite(torque)):
            self._faulted(time_s, f"returned a non-finite torque {torque.tolist()}")
            return None
        return torque

    def check_runaway(
        self, time_s: float, state: State, reference: Reference, net_torque: np.ndarray
    ) -> LawFault | None:
        """A fault once the arm moves away from the reference further than ``error_max_rad`` (counting the way a
        stop at ``stop_deceleration_rad_s2`` would still go) while the law's ``net_torque`` (less gravity's) pushes
        it on. A law braking an overshoot, or bringing the arm back to a reference that jumped, is doing its work."""
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

    def _law_terms(self) -> dict[str, Any]:
        """The user's law's terms as it reports them (none if that fails, never a reason to stop)."""
        terms = getattr(self.law, "terms", None)
        try:
            return {} if terms is None else dict(terms())
        except Exception:
            return {}

    def _reported_terms(self) -> dict[str, np.ndarray]:
        """The user's law's terms of the last update, each one finite number per joint (others are not reported)."""
        out = {}
        for name, value in self._raw_terms.items():
            try:
                array = np.broadcast_to(np.asarray(value, dtype=float), (self.joint_count,))
            except (TypeError, ValueError):
                continue
            out[name] = np.where(np.isfinite(array), array, 0.0)
        return out

    def _call(self, time_s: float | None, method: str, call: Callable[[], Any]) -> Any:
        """``call()``'s value, or the law's fault (timed: abandoned at once, shorter overruns by OVERRUN_TICKS)."""
        if self.fault is not None:
            return self.fault
        timed = self.clock is not None and method == "update"
        spent_s: list[float] = []  # the call's own time, measured on the thread it runs on
        if timed:
            call = self._timed(call, spent_s)
        over_s = self.budget_s + self.period_s  # where the world waits: the CPU time after which a call is abandoned
        waited_s, cpu_limit_s = (over_s, None) if self.abandon_s is None else (self.abandon_s, over_s)
        started_cpu_s = 0.0 if self.worker is None else self.worker.cpu_s()
        outcome = _outcome(call) if self.worker is None else self.worker.run(call, waited_s, cpu_limit_s)
        if outcome is None:
            assert self.worker is not None
            computed_s = self.worker.cpu_s() - started_cpu_s
            took = f"{waited_s * 1e3:.1f} ms"
            if cpu_limit_s is not None and computed_s >= cpu_limit_s:
                took = f"{computed_s * 1e3:.1f} ms of CPU time"
            over = " by more than a control period" if self.abandon_s is None else ""
            return self._faulted(
                time_s,
                f"was still in {method}() after {took}, over its budget of "
                f"{self.budget_s * 1e3:g} ms (law_budget_s){over}: abandoned",
            )
        value, trace = outcome
        if trace is not None:
            in_method = "" if method == "update" else f" in {method}()"
            said = f": {value}" if str(value) else ""
            return self._faulted(time_s, f"raised {type(value).__name__}{said}{in_method}", trace)
        if timed:
            duration_s = spent_s[0]
            self.overruns_s = self.overruns_s + [duration_s] if duration_s > self.budget_s else []
            if len(self.overruns_s) >= OVERRUN_TICKS:
                took = ", ".join(f"{d * 1e3:.1f}" for d in self.overruns_s)
                return self._faulted(
                    time_s,
                    f"took {took} ms in update() on {OVERRUN_TICKS} ticks running, over its budget of "
                    f"{self.budget_s * 1e3:g} ms (law_budget_s)",
                )
        return value

    def _timed(self, call: Callable[[], Any], spent_s: list[float]) -> Callable[[], Any]:
        """``call``, leaving in ``spent_s`` its time on ``clock`` less its thread's wait for a CPU (``run_wait``, read
        on that thread: a law preempted by the host is not slow)."""
        assert self.clock is not None
        clock, run_wait = self.clock, self.run_wait or (lambda: 0.0)

        def timed() -> Any:  # (less the thread's garbage collections: the interpreter's, not the law's)
            started_s, waited_s, collecting_s = clock(), run_wait(), collected_s()
            try:
                return call()
            finally:
                waited_s, collecting_s = run_wait() - waited_s, collected_s() - collecting_s
                spent_s.append(max(0.0, clock() - started_s - waited_s - collecting_s))

        return timed

    def _faulted(self, time_s: float | None, what: str, trace: str = "") -> LawFault:
        self.fault = LawFault(self.name, what, time_s, trace)
        return self.fault


def _show(value) -> str:
    if isinstance(value, np.ndarray):
        return "[" + ", ".join(f"{v:.3g}" for v in value) + "]"
    return f"{value:.3g}" if isinstance(value, float) else repr(value)
