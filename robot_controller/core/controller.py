"""The joint controller the ``pid_controller`` node runs: reference handling,
feedforward, the control law and the sensor watchdog, called once per tick.

It keeps the latest reference and measurement with the times they arrived
and, on :meth:`JointController.update`, turns them into one torque command.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.feedforward import FeedforwardMode, feedforward_torque
from robot_controller.core import lqr
from robot_controller.core.estimator import JointKalmanFilter, KalmanConfig
from robot_controller.core.pid import DerivativeSource, Pid, PidConfig, PidTerms
from robot_controller.core.plant import ArmDynamics


class Status(str, Enum):
    OK = "ok"
    HOLDING = "holding"  #: no reference yet: holding the first measured position
    NO_MEASUREMENT = "no_measurement"  #: no valid sensor message yet: zero torque
    WATCHDOG = "watchdog"  #: sensor silent for too long: zero torque


@dataclass
class ControllerConfig:
    """Options around the control law.

    :param pid: gains and limits of the law
    :param feedforward: a :class:`FeedforwardMode`
    :param control_period_s: nominal period, s
    :param reference_extrapolation: evaluate the latest reference sample at
        the tick time using its velocity and acceleration, instead of holding it
    :param latency_compensation: advance the measurement from its stamp to the
        tick time through the arm model (or its own velocity without a model)
    :param watchdog_periods: control periods without a valid measurement
        before the command drops to zero
    """

    pid: PidConfig = field(default_factory=PidConfig)
    law: str = "pid"  #: "pid", or "lqr": the PID's gains replaced by a discrete LQR design
    lqr_q: tuple[float, float, float] = (1e4, 1e4, 1.0)  #: weights on ∫e, e, ė
    lqr_r: float = 1e-2  #: weight on the feedback torque
    estimator: KalmanConfig | None = None  #: a Kalman filter on the reading, or none
    feedforward: FeedforwardMode = FeedforwardMode.NONE
    control_period_s: float = 0.01
    reference_extrapolation: bool = False
    latency_compensation: bool = False
    watchdog_periods: int = 5

    def __post_init__(self) -> None:
        try:
            self.feedforward = FeedforwardMode(self.feedforward)
        except ValueError:
            raise ConfigError(
                f"feedforward: {self.feedforward!r} is not one of {[m.value for m in FeedforwardMode]}"
            ) from None
        if not np.isfinite(self.control_period_s) or self.control_period_s <= 0:
            raise ConfigError(f"control_rate_hz: must be > 0, got period {self.control_period_s}")
        if int(self.watchdog_periods) < 1:
            raise ConfigError(f"watchdog_periods: must be >= 1, got {self.watchdog_periods}")
        if self.law not in ("pid", "lqr"):
            raise ConfigError(f"controller_type: {self.law!r} is not one of ['pid', 'lqr']")


@dataclass
class ControlOutput:
    """One tick: the command and everything that went into it."""

    time_s: float
    status: Status
    reference: np.ndarray
    measured: np.ndarray
    terms: PidTerms

    @property
    def command(self) -> np.ndarray:
        return self.terms.command

    @property
    def error(self) -> np.ndarray:
        return self.reference - self.measured


# Extrapolating further than this is guessing, not compensating.
_MAX_EXTRAPOLATION_S = 0.1
_COMMAND_HISTORY = 16
_TIME_EPS_S = 1e-6


def law_config(config: ControllerConfig, dynamics: ArmDynamics | None, joint_count: int) -> PidConfig:
    """The PID settings the law runs with. For LQR, the gains come from a
    discrete Riccati design on each joint's ``[∫e, e, ė]`` at the control rate
    (with feedforward carrying the motion, the feedback is exactly a PID on
    velocity error with these gains)."""
    if config.law == "pid":
        return config.pid
    if dynamics is None:
        raise ConfigError("controller_type lqr: needs the arm model (urdf_path)")
    inertia = np.diag(dynamics.mass_matrix(np.zeros(joint_count)))
    gains = np.array([lqr.design(inertia[j], dynamics.damping[j], config.control_period_s, np.array(config.lqr_q),
                                 config.lqr_r).K[0] for j in range(joint_count)])
    return replace(config.pid, ki=gains[:, 0], kp=gains[:, 1], kd=gains[:, 2],
                   derivative_source=DerivativeSource.VELOCITY_ERROR)


class JointController:
    def __init__(self, config: ControllerConfig, joint_count: int, dynamics: ArmDynamics | None = None) -> None:
        if config.feedforward is not FeedforwardMode.NONE and dynamics is None:
            raise ConfigError("feedforward: needs the arm model (urdf_path)")
        self.config = config
        self.joint_count = joint_count
        self.dynamics = dynamics
        self.pid = Pid(law_config(config, dynamics, joint_count))
        self.estimator = self._make_estimator(config)
        self._reference: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._planner_spoke = False  # a reference sample has arrived (not just the hold)
        self._reference_time_s = 0.0
        self.reference_period_s: float | None = None  #: learned from consecutive sample times
        self._measurement: tuple[np.ndarray, np.ndarray] | None = None
        self._measurement_stamp_s = 0.0
        self._measurement_received_s = -np.inf
        self._last_update_s: float | None = None
        self._filtered_stamp_s = -np.inf
        self._filtered: tuple[np.ndarray, np.ndarray] | None = None
        # (time issued, command) of recent ticks, newest last, for latency compensation
        self._commands: deque[tuple[float, np.ndarray]] = deque(maxlen=_COMMAND_HISTORY)

    def _make_estimator(self, config: ControllerConfig) -> JointKalmanFilter | None:
        if config.estimator is None:
            return None
        if self.dynamics is None:
            raise ConfigError("estimator kalman: needs the arm model (urdf_path)")
        return JointKalmanFilter(config.estimator, self.joint_count, self.dynamics.predict)

    @property
    def gains(self) -> PidConfig:
        """The gains in force (for LQR, the designed ones)."""
        return self.pid.config

    def set_config(self, config: ControllerConfig) -> None:
        """New gains and options, applied bumplessly from the next tick."""
        if config.feedforward is not FeedforwardMode.NONE and self.dynamics is None:
            raise ConfigError("feedforward: needs the arm model (urdf_path)")
        pid = law_config(config, self.dynamics, self.joint_count)
        if config.estimator != self.config.estimator:
            self.estimator = self._make_estimator(config)
        self.config = config
        self.pid.set_config(pid)

    def set_reference(self, received_s: float, position: np.ndarray, velocity: np.ndarray,
                      acceleration: np.ndarray, sample_time_s: float | None = None) -> None:
        """A new reference sample. Its time base is ``sample_time_s`` when the
        planner sent one, otherwise the time it arrived."""
        time_s = received_s if sample_time_s is None else sample_time_s
        self._planner_spoke = True
        if self._reference is not None and time_s > self._reference_time_s:
            self.reference_period_s = time_s - self._reference_time_s
        self._reference = (position, velocity, acceleration)
        self._reference_time_s = time_s

    def has_reference(self) -> bool:
        """Whether any reference sample has arrived."""
        return self._planner_spoke

    def reference_ready(self, tick_s: float) -> bool:
        """Whether every reference sample due by ``tick_s`` is in (lockstep):
        the latest is at least as new as the tick, or the next is not due yet."""
        if self._reference is None:
            return False
        if self._reference_time_s >= tick_s - _TIME_EPS_S:
            return True
        return (self.reference_period_s is not None
                and self._reference_time_s + self.reference_period_s > tick_s + _TIME_EPS_S)

    @property
    def measurement_stamp_s(self) -> float:
        return self._measurement_stamp_s

    def set_measurement(self, stamp_s: float, received_s: float, position: np.ndarray,
                        velocity: np.ndarray) -> None:
        self._measurement = (position, velocity)
        self._measurement_stamp_s = stamp_s
        self._measurement_received_s = received_s

    @property
    def has_measurement(self) -> bool:
        return self._measurement is not None

    def update(self, now_s: float) -> ControlOutput:
        """Compute the command for the tick at ``now_s`` seconds."""
        dt = self.config.control_period_s
        if self._last_update_s is not None and now_s > self._last_update_s:
            # The true elapsed time, within reason: a late tick integrates what really passed.
            dt = min(now_s - self._last_update_s, 5.0 * self.config.control_period_s)
        self._last_update_s = now_s

        zeros = np.zeros(self.joint_count)
        if self._measurement is None:
            return self._idle(now_s, Status.NO_MEASUREMENT, zeros, zeros)
        measured_position, measured_velocity = self._measurement
        silent_s = now_s - self._measurement_received_s
        if silent_s > self.config.watchdog_periods * self.config.control_period_s:
            self.pid.reset()
            if self.estimator is not None:
                self.estimator.reset()
            return self._idle(now_s, Status.WATCHDOG, measured_position, measured_position)

        if self.estimator is not None:
            if self._measurement_stamp_s != self._filtered_stamp_s:
                # The torque that acted since the last reading: the last command issued before it.
                self._filtered = self.estimator.update(self._measurement_stamp_s, measured_position,
                                                       measured_velocity,
                                                       self._command_before(self._measurement_stamp_s))
                self._filtered_stamp_s = self._measurement_stamp_s
            measured_position, measured_velocity = self._filtered

        if self.config.latency_compensation:
            # The reading is as old as its stamp; bring position AND velocity up to
            # now through the arm model under the torque being applied, so a stale
            # velocity does not eat the D term's phase margin.
            age = float(np.clip(now_s - self._measurement_stamp_s, 0.0, _MAX_EXTRAPOLATION_S))
            if self.dynamics is not None:
                measured_position, measured_velocity = self._predict(
                    measured_position, measured_velocity, now_s - age, now_s)
            else:
                measured_position = measured_position + measured_velocity * age

        status = Status.OK
        if self._reference is None:
            # Hold where the arm is until the planner speaks.
            self._reference = (measured_position.copy(), zeros.copy(), zeros.copy())
            self._reference_time_s = now_s
            status = Status.HOLDING
        ref_position, ref_velocity, ref_acceleration = self._reference
        if self.config.reference_extrapolation:
            age = float(np.clip(now_s - self._reference_time_s, 0.0, _MAX_EXTRAPOLATION_S))
            ref_position = ref_position + ref_velocity * age + 0.5 * ref_acceleration * age * age
            ref_velocity = ref_velocity + ref_acceleration * age

        feedforward = feedforward_torque(
            self.config.feedforward, self.dynamics, ref_position, ref_velocity, ref_acceleration
        )
        terms = self.pid.step(dt, ref_position, ref_velocity, measured_position, measured_velocity, feedforward)
        self._remember_command(now_s, terms.command)
        return ControlOutput(now_s, status, ref_position, measured_position, terms)

    def _command_before(self, time_s: float) -> np.ndarray:
        torque = np.zeros(self.joint_count)
        for issued_s, command in self._commands:
            if issued_s < time_s - _TIME_EPS_S:
                torque = command
        return torque

    def _remember_command(self, now_s: float, command: np.ndarray) -> None:
        self._commands.append((now_s, np.array(command, dtype=float)))

    def _predict(self, position: np.ndarray, velocity: np.ndarray, from_s: float, to_s: float
                 ) -> tuple[np.ndarray, np.ndarray]:
        """Integrate the arm model from ``from_s`` to ``to_s`` under the commands
        this controller issued in between (each acting from its tick on)."""
        assert self.dynamics is not None
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
            position, velocity = self.dynamics.predict(position, velocity, torque, issued_s - t)
            t, torque = issued_s, command
        if to_s > t:
            position, velocity = self.dynamics.predict(position, velocity, torque, to_s - t)
        return position, velocity

    def _idle(self, now_s: float, status: Status, reference: np.ndarray, measured: np.ndarray) -> ControlOutput:
        zeros = np.zeros(self.joint_count)
        self._remember_command(now_s, zeros)
        terms = PidTerms(zeros, zeros, zeros, zeros, zeros, np.zeros(self.joint_count, dtype=bool))
        return ControlOutput(now_s, status, np.asarray(reference, float), np.asarray(measured, float), terms)
