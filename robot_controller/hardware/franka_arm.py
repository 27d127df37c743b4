"""A Franka arm through libfranka (pylibfranka, Franka's own bindings) in torque control: connect, recover, read the
robot's state each millisecond, write a torque, finish. The robot keeps the clock: each ``read`` blocks until its
next state and says how much of the robot's time has passed. A reflex or a broken link arrives as libfranka's
exception; here it is a :class:`RobotFault` naming the reflexes, in the words libfranka's ``Errors`` use.

``franka://HOST`` names the robot: libfranka has no port to choose (its command port is 1337)."""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any
from urllib.parse import urlparse

import numpy as np

SCHEME = "franka"
#: kg·m² on every joint: the rotors' inertia reflected through the gears, which the Panda's URDF leaves out and the
#: MuJoCo Menagerie's FR3 carries (the model franka-sim's servo gains are tuned on). The stand-in's arm has it; the
#: controller's model is given it on a Franka (``robot_loop``).
ROTOR_INERTIA_KGM2 = 0.195


class RobotFault(Exception):
    """The robot ended the motion (a reflex) or the link to it failed: ``reflexes`` its error names (may be empty),
    ``message`` libfranka's own line."""

    def __init__(self, reflexes: list[str], message: str) -> None:
        super().__init__(message)
        self.reflexes = reflexes
        self.message = message

    def describe(self) -> str:
        """``joint_velocity_violation, …`` when the robot named its reflexes, else libfranka's line."""
        return ", ".join(self.reflexes) if self.reflexes else self.message


@dataclass(frozen=True)
class RobotReading:
    """One state of the robot: ``time_s`` when it arrived, on this host's monotonic clock since the first; the robot's
    own time (its states counted, ``robot_time_s``) and the periods that passed without one (``missed``); the
    joints' ``position`` (rad), ``velocity`` (rad/s), ``torque_nm`` (measured, tau_J); ``success_rate`` the share of
    the last commands the robot received in time (libfranka's ``control_command_success_rate``).

    Why the arrival, not the robot's count, stamps it: both are real time on a real robot (its states come every
    millisecond), but the stand-in's physics keeps wall time while its state stream waits for each command, so its
    count ran up to 3 % behind its physics and every joint lagged its reference by that much."""

    time_s: float
    arrived_s: float  #: ``time.monotonic()`` when it arrived
    robot_time_s: float
    missed: int
    position: np.ndarray
    velocity: np.ndarray
    torque_nm: np.ndarray
    commanded_nm: np.ndarray  #: the torque the robot last took from us (tau_J_d), gravity left out
    success_rate: float


#: s a read must wait for its state to be taken as arriving on its return (shorter: it was there already)
WAITED_S = 50e-6


def parse_hardware(text: str) -> str:
    """``franka://HOST`` → HOST, or ValueError saying what is wrong."""
    parsed = urlparse(text)
    if parsed.scheme != SCHEME or not parsed.hostname:
        raise ValueError(f"--hardware {text!r}: franka://HOST (the robot's address; libfranka's port is fixed)")
    if parsed.port is not None or parsed.path not in ("", "/"):
        raise ValueError(f"--hardware {text!r}: only a host, e.g. franka://172.16.0.2 (libfranka picks the port)")
    return parsed.hostname


@contextlib.contextmanager
def scheduling_kept() -> Iterator[None]:
    """The calling thread's scheduling as it was, whatever libfranka does meanwhile. Its ``Robot`` raises the thread
    that makes it to SCHED_FIFO 99 wherever it may (``RealtimeConfig.kIgnore`` only ignores a refusal): as root the
    test session's main thread became real-time, and every process it started after inherited it: a split run's nodes
    spun at priority 99, starving the host for 13 minutes. Real-time here is chosen (``--realtime``), never caught."""
    policy, param = os.sched_getscheduler(0), os.sched_getparam(0)
    try:
        yield
    finally:
        with contextlib.suppress(OSError):
            os.sched_setscheduler(0, policy, param)


def error_names(errors: Any) -> list[str]:
    """The names of the errors set in a libfranka ``Errors`` (empty: none)."""
    return [name for name in dir(errors) if not name.startswith("_") and getattr(errors, name) is True]


class FrankaArm:
    """The robot at ``host`` in torque control, through pylibfranka (imported here: the ``franka`` extra)."""

    def __init__(self, host: str, period_s: float = 0.001) -> None:
        import pylibfranka

        self._franka = pylibfranka
        # libfranka's exceptions share no base (ControlException is a RuntimeError, FrankaException is not)
        self._failures = tuple(getattr(pylibfranka, name) for name in dir(pylibfranka) if name.endswith("Exception"))
        self.host = host
        self.period_s = period_s
        # (libfranka's connect has no timeout, and pylibfranka holds the interpreter while it waits: a robot busy
        # with another client keeps this waiting; a thread cannot bound it)
        try:
            with scheduling_kept():
                self.robot = pylibfranka.Robot(host, pylibfranka.RealtimeConfig.kIgnore)
        except self._failures as exc:
            raise RobotFault([], f"cannot reach the Franka at {host}: {exc}") from None
        self._control: Any = None
        self.time_s = 0.0  #: the robot's own time since control started (its states counted)
        self._started_s: float | None = None  # time.monotonic() at the first state
        self._last_arrived_s = 0.0

    def position(self) -> np.ndarray:
        """Where the arm stands now, rad (read outside any control)."""
        try:
            return np.array(self.robot.read_once().q)
        except self._failures as exc:
            raise self._fault(exc) from None

    def errors(self) -> list[str]:
        """The robot's errors now (a reflex from the last run leaves them set until recovered)."""
        return error_names(self.robot.read_once().current_errors)

    def recover(self) -> None:
        """libfranka's automatic error recovery: the robot out of its reflex state, ready to move."""
        try:
            self.robot.automatic_error_recovery()
        except self._failures as exc:
            raise RobotFault([], f"the Franka's error recovery failed: {exc}") from None

    def recover_if_needed(self, say: Callable[[str], None]) -> None:
        """A reflex a last run left (its drive killed, a fault) cleared, said in one line; nothing said if none."""
        if errors := self.errors():
            say(f"the robot reports {', '.join(errors)} (from before): recovering it (automatic error recovery)")
            self.recover()

    def start(self) -> RobotReading:
        """Torque control from now; the first state (time 0)."""
        try:
            with scheduling_kept():
                self._control = self.robot.start_torque_control()
        except self._failures as exc:
            raise self._fault(exc) from None
        self.time_s, self._started_s = 0.0, None
        return self.read()

    def read(self) -> RobotReading:
        """The robot's next state (blocks until it comes)."""
        called_s = time.monotonic()
        try:
            state, duration = self._control.readOnce()
        except self._failures as exc:
            raise self._fault(exc) from None
        returned_s = time.monotonic()
        elapsed_s = duration.to_sec()
        if self._started_s is None or returned_s - called_s > WAITED_S:
            arrived_s = returned_s  # it came while we waited for it
        else:
            # It was waiting for us (this host kept us late): it came when the robot sent it, its period after the
            # last, and no later than we asked. Stamped on its return, the state would be older than its stamp by
            # our lateness, and every moving joint would seem to lag its reference by that much.
            arrived_s = max(min(called_s, self._last_arrived_s + elapsed_s), self._last_arrived_s + 1e-6)
        if self._started_s is None:
            self._started_s = arrived_s
        self._last_arrived_s = arrived_s
        self.time_s += elapsed_s
        return RobotReading(
            time_s=arrived_s - self._started_s,
            arrived_s=arrived_s,
            robot_time_s=self.time_s,
            missed=max(0, round(elapsed_s / self.period_s) - 1),
            position=np.array(state.q),
            velocity=np.array(state.dq),
            torque_nm=np.array(state.tau_J),
            commanded_nm=np.array(state.tau_J_d),
            success_rate=float(state.control_command_success_rate),
        )

    def write(self, torque_nm: np.ndarray, *, finished: bool = False) -> None:
        """Command ``torque_nm`` (gravity left out: the robot adds its own); ``finished``: the motion ends with it."""
        command = self._franka.Torques([float(x) for x in torque_nm])
        if finished:
            command.motion_finished = True
        try:
            self._control.writeOnce(command)
        except self._failures as exc:
            raise self._fault(exc) from None

    def finish(self) -> None:
        """End torque control with nothing commanded (the robot holds where it is)."""
        if self._control is not None:
            try:
                self._control.readOnce()
                self.write(np.zeros(7), finished=True)
            except RobotFault:
                pass  # the motion is over either way
            self._control = None

    def stop(self) -> None:
        """libfranka's stop: any motion ends at once (the robot's own controlled stop)."""
        self._control = None
        if self.robot is not None:
            with contextlib.suppress(*self._failures):
                self.robot.stop()

    def close(self) -> None:
        """Let go of the robot: its connection closes (another client, or the next run, can connect)."""
        self.stop()
        self.robot = None

    def _fault(self, exc: Exception) -> RobotFault:
        """``exc`` as a fault; the motion is over, so its control object goes (it holds the robot until it does)."""
        self._control = None
        message = str(exc).strip()
        try:
            named = error_names(self.robot.read_once().last_motion_errors)
        except self._failures:
            named = []
        found = named or [name for name in _ERROR_NAMES if name in message]
        return RobotFault(found, message)


def _all_error_names() -> tuple[str, ...]:
    try:
        import pylibfranka
    except ImportError:
        return ()
    return tuple(name for name in dir(pylibfranka.Errors) if not name.startswith("_"))


_ERROR_NAMES = _all_error_names()
