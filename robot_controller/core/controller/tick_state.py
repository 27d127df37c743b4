"""The arm's state at the tick, from a reading taken earlier: filtered, then advanced from its stamp to the tick
on the arm model under the torques this controller issued (latency compensation), or coasted on the model while
readings are missing; with the disturbance observer, the estimated external torque included."""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

import numpy as np

from robot_controller.core.controller.config import ControllerConfig
from robot_controller.core.controller.inertia_adaptation import InertiaAdaptation
from robot_controller.core.controller.supervision import PositionNoise, Readings
from robot_controller.core.errors import ConfigError
from robot_controller.core.estimation import JointKalmanFilter
from robot_controller.core.laws.pid import Pid
from robot_controller.core.model import ArmDynamics
from robot_controller.core.model.drive_lag import LagInversion

# Extrapolating further than this (s) is guessing, not compensating.
MAX_EXTRAPOLATION_S = 0.1
TIME_EPS_S = 1e-6
_COMMAND_HISTORY = 16
# Filtered positions kept (one per reading): 0.5 s of a 100 Hz sensor, longer than any camera reading may be late.
_FILTERED_HISTORY = 50
# Coasting, the observer's estimate held is its average over this long (s): open loop, a transient
# in it is a torque on the arm for as long as readings stay away; the average keeps a payload's
# torque (96 % of one that came a second before) and drops transients (a 50 ms one to a fifth).
DISTURBANCE_HOLD_AVERAGE_S = 0.25


def clipped_age_s(now_s: float, sample_s: float) -> float:
    """How old (s) a sample taken at ``sample_s`` is at ``now_s``, within [0, MAX_EXTRAPOLATION_S]."""
    return min(max(float(now_s - sample_s), 0.0), MAX_EXTRAPOLATION_S)  # (NaN stays NaN)


def make_estimator(
    config: ControllerConfig, dynamics: ArmDynamics | None, joint_count: int
) -> JointKalmanFilter | None:
    """The Kalman filter ``config.estimator`` asks for on the arm model (None: none asked for)."""
    if config.estimator is None:
        return None
    if dynamics is None:
        raise ConfigError("estimator kalman: needs the arm model (urdf_path)")
    return JointKalmanFilter(
        config.estimator,
        joint_count,
        dynamics.predict,
        transition=dynamics.transition,
        estimate_disturbance=config.observes_disturbance,
        mass_matrix=dynamics.mass_matrix,
        disturbance_limit=config.pid.output_limit,
        torque_scale=config.observer_torque_scale(dynamics, joint_count),
        payload_torque_std=config.payload_torque_std(dynamics, joint_count),
    )


def make_state(
    config: ControllerConfig,
    dynamics: ArmDynamics | None,
    joint_count: int,
    pid: Callable[[], Pid],
    config_in_force: Callable[[], ControllerConfig] | None = None,
) -> StateAtTick:
    """The controller's state at its ticks: its filter and, with the observer, the :class:`InertiaAdaptation`
    (``config_in_force``: the configuration its gains are checked with, None: ``config``)."""
    state = StateAtTick(joint_count, dynamics, make_estimator(config, dynamics, joint_count))
    state.inertia = InertiaAdaptation.build(config, dynamics, joint_count, pid, config_in_force)
    if config.model_drive_lag_s > 0:
        state.drive_lag = LagInversion(config.model_drive_lag_s, np.broadcast_to(config.pid.output_limit, joint_count))
    return state


class StateAtTick:
    """The arm's ``(position, velocity)`` at a tick, and the commands issued (the filter's and the model's input)."""

    def __init__(self, joint_count: int, dynamics: ArmDynamics | None, kalman: JointKalmanFilter | None) -> None:
        self.joint_count = joint_count
        self.dynamics = dynamics
        self.kalman = kalman
        self._filtered_stamp_s = -np.inf
        self._filtered: tuple[np.ndarray, np.ndarray] | None = None
        # (time issued s, command N·m) of recent ticks, newest last
        self._commands: deque[tuple[float, np.ndarray]] = deque(maxlen=_COMMAND_HISTORY)
        #: (position, velocity, time s) of the latest estimate, None after a reset
        self.latest: tuple[np.ndarray, np.ndarray, float] | None = None
        #: the observer's state per joint averaged over DISTURBANCE_HOLD_AVERAGE_S, and when last updated
        self._disturbance_average: list[float] | None = None
        self._average_s = 0.0
        self._coasting = False  #: the model coasts on the average: readings are missing
        #: (stamp s, filtered position) after each reading, newest last: where a late camera's reading is brought from
        self._history: deque[tuple[float, np.ndarray]] = deque(maxlen=_FILTERED_HISTORY)
        #: a second sensor's late reading (stamp s, position, what it says of its errors) waiting for the next tick
        self._second: tuple[float, np.ndarray, PositionNoise] | None = None
        #: keeps the model's and the gains' inertia the arm's, after each reading (None: they stay as designed)
        self.inertia: InertiaAdaptation | None = None
        #: the drive's lag, inverted: each command is what makes the torque applied the law's (None: no lag known)
        self.drive_lag: LagInversion | None = None

    def reset(self) -> None:
        """Start again from the next reading: filter re-initialised, no estimate carried over."""
        self.reset_filter()
        self.latest = None

    def reset_filter(self) -> None:
        """Re-initialise the filter only; the latest estimate is kept for reporting."""
        if self.kalman is not None:
            self.kalman.reset()
        if self.inertia is not None:  # the filter's evidence is gone: so is the estimate's
            self.inertia.interrupted()
        self._filtered_stamp_s = -np.inf
        self._disturbance_average, self._coasting = None, False
        self._history.clear()
        self._second = None

    def at_tick(self, now_s: float, readings: Readings, latency_compensation: bool) -> tuple[np.ndarray, np.ndarray]:
        """The reading, filtered, then (with ``latency_compensation``) brought from its stamp to ``now_s``, position
        and velocity, on the model under the torque applied, so a stale velocity does not eat the D term's phase
        margin. With the filter, the velocity at the tick's instant is returned; :attr:`latest` keeps the model's."""
        position, velocity = readings.latest
        kalman, stamp_s = self.kalman, readings.stamp_s
        if kalman is not None:
            if stamp_s != self._filtered_stamp_s:
                # The torque that acted since the last reading: the last command issued before it; how
                # much it changed matters only to a filter unsure when a command takes effect.
                if readings.noise is not None:
                    # A camera's reading comes slower than the commands: each acts over its own span.
                    for issued_s, _ in self.commands_between(self._filtered_stamp_s, stamp_s):
                        kalman.advance(issued_s, self.command_before(issued_s))
                command = self.command_before(stamp_s)
                change = None
                if kalman.config.command_timing_uncertainty_s > 0:
                    change = self.command_change(self._filtered_stamp_s, stamp_s)
                self._filtered = kalman.update(stamp_s, position, velocity, command, change, readings.noise)
                self._filtered_stamp_s = stamp_s
                self._history.append((stamp_s, self._filtered[0]))
                self._average_disturbance(stamp_s)
                if self.inertia is not None:
                    self.inertia.after_reading(stamp_s, kalman, command)
            if self._second is not None:
                self._fuse_second()
            position, velocity = self._filtered
        if latency_compensation:
            age_s = clipped_age_s(now_s, stamp_s)
            if self.dynamics is not None:
                position, velocity = self.predict(position, velocity, now_s - age_s, now_s)
            else:
                position = position + velocity * age_s
        self.latest = (position, velocity, now_s)
        if kalman is not None:  # the filter's model step velocity → the velocity at the tick
            velocity = kalman.velocity_at_instant(position, velocity, self.last_command())
            self._coasting = False
        return position, velocity

    def take_second(self, stamp_s: float, position: np.ndarray, noise: PositionNoise) -> None:
        """A second sensor's reading of the positions alone (a camera's beside the encoder), later than the filter's
        readings: fused at the next tick."""
        self._second = (stamp_s, position, noise)

    def _fuse_second(self) -> None:
        """The second sensor's reading brought to the filter's time by the filter's own motion since its stamp (the
        filtered position then, from the history), then fused on the positions alone. One older than the history, or
        from before the filter's first reading, is dropped."""
        stamp_s, position, noise = self._second
        self._second = None
        then = None
        for filtered_s, filtered in reversed(self._history):
            if filtered_s <= stamp_s + TIME_EPS_S:
                then = filtered
                break
        if then is None or self.kalman.x is None:
            return
        moved = self._filtered[0] - then
        self._filtered = self.kalman.correct_position(position + moved, *noise)

    def _average_disturbance(self, now_s: float) -> None:
        """Fold the observer's state after a reading into its running average (first order, on floats)."""
        state = self.kalman.disturbance_state
        average = self._disturbance_average
        if state is None or average is None:
            self._disturbance_average = state
        else:
            weight = min(max((now_s - self._average_s) / DISTURBANCE_HOLD_AVERAGE_S, 0.0), 1.0)
            self._disturbance_average = [a + weight * (x - a) for a, x in zip(average, state, strict=True)]
        self._average_s = now_s

    def coast(self, now_s: float, readings: Readings) -> tuple[np.ndarray, np.ndarray]:
        """While readings are missing: the latest estimate (or reading) carried on to ``now_s`` on the model under
        the last command, open loop. Without a model it stays put."""
        if self.latest is None:
            self.latest = (readings.latest[0], readings.latest[1], now_s)
        if not self._coasting:
            self._coasting = True
            if self.kalman is not None and self._disturbance_average is not None:
                self.kalman.set_disturbance_state(self._disturbance_average)
        position, velocity, estimate_s = self.latest
        if self.dynamics is not None and now_s > estimate_s:
            position, velocity = self._model(position, velocity, self.last_command(), now_s - estimate_s)
        self.latest = (position, velocity, now_s)
        return position, velocity

    def disturbance(self) -> np.ndarray | None:
        """The observer's external torque per joint (N·m), or None without one."""
        if self.kalman is None or not self.kalman.estimates_disturbance:
            return None
        return self.kalman.disturbance

    def _model(
        self, position: np.ndarray, velocity: np.ndarray, torque: np.ndarray, horizon_s: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """The arm model ``horizon_s`` ahead under ``torque`` (with the observer, its torque included)."""
        if self.kalman is not None and self.kalman.estimates_disturbance:
            return self.kalman.predict(position, velocity, torque, horizon_s)
        return self.dynamics.predict(position, velocity, torque, horizon_s)

    def last_position(self, readings: Readings) -> np.ndarray:
        """The latest estimated position (rad), or the latest reading's without one."""
        return self.latest[0] if self.latest is not None else readings.latest[0]

    @staticmethod
    def reading_alone(
        now_s: float, readings: Readings, latency_compensation: bool, held: bool = False
    ) -> tuple[np.ndarray, np.ndarray]:
        """The reading brought to ``now_s`` on its own velocity (with ``latency_compensation``): after a fault the
        last commands are no guide. ``held``: the brakes hold the arm where the reading put it, at rest."""
        position, velocity = readings.latest
        if held:
            return position, np.zeros_like(position)
        if latency_compensation:
            position = position + velocity * clipped_age_s(now_s, readings.stamp_s)
        return position, velocity

    def held(self, now_s: float, readings: Readings) -> tuple[np.ndarray, np.ndarray]:
        """The arm as the drive's brakes hold it: where the latest reading put it, at rest. A reading taken
        before they caught it is not advanced on its velocity or the model: the arm stood since (advanced, one
        taken 40 ms before a brake at 3 rad/s put the arm 0.11 rad from where it stood)."""
        position, velocity = self.reading_alone(now_s, readings, False, held=True)
        self.latest = (position, velocity, now_s)
        return position, velocity

    # --- commands issued ------------------------------------------------------------

    def remember_command(self, now_s: float, command: np.ndarray) -> None:
        """Record the torque (N·m) issued at ``now_s``."""
        self._commands.append((now_s, np.array(command, dtype=float)))

    def issue(self, now_s: float, wanted: np.ndarray, period_s: float) -> np.ndarray:
        """The command that makes the drive apply ``wanted`` (N·m per joint) from ``now_s``: itself, or through the
        drive's lag inverted (``period_s``: since the last command, the first's nominal); the torque applied is what
        is remembered (the filter's input)."""
        lag = self.drive_lag
        if lag is None:
            self.remember_command(now_s, wanted)
            return wanted
        if self._commands and now_s > self._commands[-1][0]:
            period_s = now_s - self._commands[-1][0]
        command = lag.command(wanted, period_s)
        self.remember_command(now_s, lag.applied)
        return command

    def drive_stopped(self, now_s: float) -> None:
        """No command: the drive's torque goes (its timeout, a brake), and with it its lag's state."""
        if self.drive_lag is not None:
            self.drive_lag.reset()
        self.remember_command(now_s, np.zeros(self.joint_count))

    def last_command(self) -> np.ndarray:
        return self._commands[-1][1] if self._commands else np.zeros(self.joint_count)

    def command_before(self, time_s: float) -> np.ndarray:
        """The last command issued strictly before ``time_s`` (zero before any)."""
        for issued_s, command in reversed(self._commands):
            if issued_s < time_s - TIME_EPS_S:
                return command
        return np.zeros(self.joint_count)

    def commands_between(self, from_s: float, to_s: float) -> list[tuple[float, np.ndarray]]:
        """The commands issued strictly between ``from_s`` and ``to_s`` (s), oldest first."""
        return [(t, c) for t, c in self._commands if from_s + TIME_EPS_S < t < to_s - TIME_EPS_S]

    def command_change(self, from_s: float, to_s: float) -> np.ndarray:
        """How much the commands issued in ``[from_s, to_s)`` changed the command (N·m per joint, root sum of
        squares of each change)."""
        squared = [0.0] * self.joint_count  # (Python's floats: a change or two per reading, on a few joints)
        before: np.ndarray | None = None
        start_s, end_s = from_s - TIME_EPS_S, to_s - TIME_EPS_S
        for issued_s, command in self._commands:
            if issued_s < start_s:
                before = command
            elif issued_s < end_s:
                if before is not None:
                    change = [c - b for c, b in zip(command.tolist(), before.tolist(), strict=True)]
                    squared = [s + d * d for s, d in zip(squared, change, strict=True)]
                before = command
        return np.sqrt(squared)

    def predict(
        self, position: np.ndarray, velocity: np.ndarray, from_s: float, to_s: float
    ) -> tuple[np.ndarray, np.ndarray]:
        """The arm model from ``from_s`` to ``to_s`` under the commands issued in between, each from its tick."""
        assert self.dynamics is not None
        if to_s <= from_s:  # nothing to integrate (a reading stamped at the tick)
            return position, velocity
        torque = np.zeros(self.joint_count)
        segments: list[tuple[float, np.ndarray]] = []
        for issued_s, command in self._commands:
            if issued_s <= from_s:
                torque = command
            else:
                segments.append((issued_s, command))
        t = from_s
        for issued_s, command in segments:
            if issued_s >= to_s:
                break
            position, velocity = self._model(position, velocity, torque, issued_s - t)
            t, torque = issued_s, command
        if to_s > t:
            position, velocity = self._model(position, velocity, torque, to_s - t)
        return position, velocity
