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
from robot_controller.core.safe_motion import Blend, ControlledStop


class Status(str, Enum):
    OK = "ok"
    HOLDING = "holding"  #: no reference yet: holding the first measured position
    NO_MEASUREMENT = "no_measurement"  #: no valid sensor message yet: no command
    WATCHDOG = "watchdog"  #: readings missing: controlled stop on the model's estimate (category 2)
    SENSOR_LOST = "sensor_lost"  #: readings missing past sensor_timeout_s: no command, the brake holds (category 1)
    REACQUIRING = "reacquiring"  #: a fault cleared: led from where the arm is back onto the trajectory
    REFERENCE_LOST = "reference_lost"  #: the planner went quiet: controlled stop of the reference, holding
    STOPPED = "stopped"  #: e-stop or brake: no command until it lifts

    @property
    def commanding(self) -> bool:
        """Whether a tick in this state sends a torque to the motor."""
        return self not in (Status.NO_MEASUREMENT, Status.SENSOR_LOST, Status.STOPPED)


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
    sensor_timeout_s: float = 1.0  #: readings missing this long end the controlled stop: torque off, brake
    #: s; a reading older than this when it arrives (or stamped this far ahead) is refused: after a
    #: pause, a sensor's first sample can be from before it, and acting on it swings the arm
    max_reading_age_s: float = 0.1
    stop_deceleration: float = 20.0  #: rad/s², controlled stops (sensor or planner lost)
    reacquire_acceleration: float = 20.0  #: rad/s², the blend back onto the trajectory after a fault

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
        for name in ("sensor_timeout_s", "max_reading_age_s", "stop_deceleration", "reacquire_acceleration"):
            value = getattr(self, name)
            if not np.isfinite(value) or value <= 0:
                raise ConfigError(f"{name}: must be a finite number > 0, got {value}")
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
# A gap this many periods long between this controller's own ticks means it
# was not running (frozen, starved): the arm was stopped without it meanwhile.
REACQUIRE_GAP_PERIODS = 5
# The planner counts as silent after this many of its periods without a sample.
REFERENCE_TIMEOUT_PERIODS = 5
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
        # Fault handling: the latest estimate (q, v, time), the reference last used,
        # the stops and the blend in progress.
        self._estimate: tuple[np.ndarray, np.ndarray, float] | None = None
        self._last_reference: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._last_reference_s = 0.0
        self._sensor_stop: ControlledStop | None = None
        self._reference_stop: ControlledStop | None = None
        self._blend: Blend | None = None
        # Start as after a fault: lead the arm from where it is onto the trajectory.
        self._needs_reacquire = True
        self._hold_position: np.ndarray | None = None
        self._halted = False
        self._braked = False

    def _make_estimator(self, config: ControllerConfig) -> JointKalmanFilter | None:
        if config.estimator is None:
            return None
        if self.dynamics is None:
            raise ConfigError("estimator kalman: needs the arm model (urdf_path)")
        return JointKalmanFilter(config.estimator, self.joint_count, self.dynamics.predict)

    def delay_margin_periods(self) -> int | None:
        """Whole control periods of delay nobody accounts for (a late command, a
        reading stamped on arrival) the feedback survives, on the worst joint:
        the gains in force on the arm linearised at rest, as
        :func:`lqr.delay_margin_periods` reckons it. None without the arm model.

        Delay the stamps show is compensated on the model (``latency_compensation``);
        this is the margin for the rest, e.g. the controller → motor → simulator path.
        """
        if self.dynamics is None:
            return None
        gains = self.pid.config
        inertia = np.diag(self.dynamics.mass_matrix(np.zeros(self.joint_count)))
        margins = []
        for j in range(self.joint_count):
            A, B = lqr.discretise(float(inertia[j]), float(self.dynamics.damping[j]), self.config.control_period_s)
            K = np.array([[gains.ki[j], gains.kp[j], gains.kd[j]]], dtype=float)
            margins.append(lqr.delay_margin_periods(A, B, K))
        return min(margins)

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
                        velocity: np.ndarray) -> str | None:
        """Take a reading stamped ``stamp_s`` that arrived at ``received_s``.

        Returns why it was refused (it is then not a sign of life for the
        watchdog either), or None.
        """
        age_s = received_s - stamp_s
        if abs(age_s) > self.config.max_reading_age_s:
            when = "old" if age_s > 0 else "in the future"
            return f"reading stamped {abs(age_s):.3f} s {when} (max_reading_age_s {self.config.max_reading_age_s:g})"
        self._measurement = (position, velocity)
        self._measurement_stamp_s = stamp_s
        self._measurement_received_s = received_s
        return None

    @property
    def has_measurement(self) -> bool:
        return self._measurement is not None

    def halt(self, halted: bool) -> None:
        """An e-stop holds the drive: command nothing; when it is released,
        re-acquire from the measurement."""
        if halted and not self._halted:
            self._needs_reacquire = True
        self._halted = halted

    def brakes(self, engaged: bool) -> None:
        """The drive reports its brakes. While they hold, whatever this
        controller commands does not move the arm: start again from the
        measurement every tick (no integral winds up), so the release finds a
        reference that begins where the arm is."""
        self._braked = engaged

    def update(self, now_s: float) -> ControlOutput:
        """Compute the command for the tick at ``now_s`` seconds: supervise the
        inputs, estimate the arm's state, take the reference for this tick,
        run the law."""
        dt = self.config.control_period_s
        if self._last_update_s is not None and now_s > self._last_update_s:
            gap_s = now_s - self._last_update_s
            if gap_s > REACQUIRE_GAP_PERIODS * self.config.control_period_s:
                self._needs_reacquire = True  # this controller itself was not running: the world moved on
                if gap_s <= self.config.max_reading_age_s:
                    # A brief pause of this process (the whole machine stalls at times): the
                    # readings it held back are on their way, so that time is not the sensor's silence.
                    self._measurement_received_s += gap_s - self.config.control_period_s
            dt = min(gap_s, REACQUIRE_GAP_PERIODS * self.config.control_period_s)
        self._last_update_s = now_s

        zeros = np.zeros(self.joint_count)
        if self._measurement is None:
            return self._idle(now_s, Status.NO_MEASUREMENT, zeros, zeros)
        if self._halted:
            return self._idle(now_s, Status.STOPPED, self._measurement[0], self._measurement[0])
        silent_s = now_s - self._measurement_received_s
        if silent_s > self.config.sensor_timeout_s:
            # Category 1: the controlled stop is over; torque off, the drive's brake holds.
            self._needs_reacquire = True
            estimate = self._estimate[0] if self._estimate is not None else self._measurement[0]
            return self._idle(now_s, Status.SENSOR_LOST, estimate, estimate)
        if silent_s > self.config.watchdog_periods * self.config.control_period_s:
            return self._controlled_stop_on_model(now_s, dt)

        if self._braked:
            self._needs_reacquire = True
        if self._needs_reacquire and not self._reacquire(now_s):
            # No fresh reference to lead the arm onto yet: hold it where it is.
            position, velocity = self._estimate_now(now_s)
            hold = self._hold_position if self._hold_position is not None else position
            self._hold_position = hold
            status = Status.HOLDING if not self._planner_spoke else Status.REACQUIRING
            return self._law(now_s, dt, status, position, velocity, hold, zeros, zeros)
        self._hold_position = None  # a later hold starts where the arm is then
        position, velocity = self._estimate_now(now_s)
        ref_position, ref_velocity, ref_acceleration, status = self._reference_now(now_s, position)
        return self._law(now_s, dt, status, position, velocity, ref_position, ref_velocity, ref_acceleration)

    # --- steps --------------------------------------------------------------------

    def _estimate_now(self, now_s: float) -> tuple[np.ndarray, np.ndarray]:
        """The arm's state at ``now_s``: the reading, filtered, advanced from its stamp."""
        position, velocity = self._measurement
        if self.estimator is not None:
            if self._measurement_stamp_s != self._filtered_stamp_s:
                # The torque that acted since the last reading: the last command issued before it.
                self._filtered = self.estimator.update(self._measurement_stamp_s, position, velocity,
                                                       self._command_before(self._measurement_stamp_s))
                self._filtered_stamp_s = self._measurement_stamp_s
            position, velocity = self._filtered
        if self.config.latency_compensation:
            # The reading is as old as its stamp; bring position AND velocity up to
            # now through the arm model under the torque being applied, so a stale
            # velocity does not eat the D term's phase margin.
            age = float(np.clip(now_s - self._measurement_stamp_s, 0.0, _MAX_EXTRAPOLATION_S))
            if self.dynamics is not None:
                position, velocity = self._predict(position, velocity, now_s - age, now_s)
            else:
                position = position + velocity * age
        self._estimate = (position, velocity, now_s)
        return position, velocity

    def _trajectory_now(self, now_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        """The planner's reference at ``now_s`` and whether it is fresh. Held
        (or extrapolated, with its velocity and acceleration) from the latest sample."""
        ref_position, ref_velocity, ref_acceleration = self._reference
        age = now_s - self._reference_time_s
        fresh = age <= self._reference_timeout_s()
        if self.config.reference_extrapolation:
            age = float(np.clip(age, 0.0, _MAX_EXTRAPOLATION_S))
            ref_position = ref_position + ref_velocity * age + 0.5 * ref_acceleration * age * age
            ref_velocity = ref_velocity + ref_acceleration * age
        return ref_position, ref_velocity, ref_acceleration, fresh

    def _reference_timeout_s(self) -> float:
        period = self.reference_period_s if self.reference_period_s is not None else self.config.control_period_s
        return max(REFERENCE_TIMEOUT_PERIODS * period, _MAX_EXTRAPOLATION_S)

    def _reference_now(self, now_s: float, position: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, Status]:
        """The reference for this tick: the trajectory, or while re-acquiring the
        trajectory plus a fading offset, or a controlled stop if the planner went quiet."""
        zeros = np.zeros(self.joint_count)
        if self._reference is None:
            # Hold where the arm is until the planner speaks.
            self._reference = (position.copy(), zeros.copy(), zeros.copy())
            self._reference_time_s = now_s
        if not self._planner_spoke:
            return *self._reference, Status.HOLDING
        ref_position, ref_velocity, ref_acceleration, fresh = self._trajectory_now(now_s)
        if not fresh:
            if self._reference_stop is None:
                # From the last reference used, carried on to now at its velocity: no jump.
                last = self._last_reference or (ref_position, ref_velocity, ref_acceleration)
                carried = np.clip(now_s - self._last_reference_s, 0.0, _MAX_EXTRAPOLATION_S)
                self._reference_stop = ControlledStop(now_s, last[0] + last[1] * carried, last[1],
                                                      self.config.stop_deceleration)
                self._blend = None
            position_r, velocity_r, acceleration_r = self._reference_stop.at(now_s)
            self._last_reference, self._last_reference_s = (position_r, velocity_r, acceleration_r), now_s
            return position_r, velocity_r, acceleration_r, Status.REFERENCE_LOST
        if self._reference_stop is not None:
            # The planner is back: lead from the stop onto its trajectory.
            held = self._reference_stop.at(now_s)
            self._blend = Blend.starting(now_s, held[0] - ref_position, held[1] - ref_velocity,
                                         self.config.reacquire_acceleration)
            self._reference_stop = None
        status = Status.OK
        if self._blend is not None:
            if self._blend.done(now_s):
                self._blend = None
            else:
                offset = self._blend.offset_at(now_s)
                ref_position, ref_velocity, ref_acceleration = (
                    ref_position + offset[0], ref_velocity + offset[1], ref_acceleration + offset[2])
                status = Status.REACQUIRING
        self._last_reference, self._last_reference_s = (ref_position, ref_velocity, ref_acceleration), now_s
        return ref_position, ref_velocity, ref_acceleration, status

    def _law(self, now_s: float, dt: float, status: Status, position: np.ndarray, velocity: np.ndarray,
             ref_position: np.ndarray, ref_velocity: np.ndarray, ref_acceleration: np.ndarray) -> ControlOutput:
        feedforward = feedforward_torque(self.config.feedforward, self.dynamics, ref_position, ref_velocity,
                                         ref_acceleration)
        terms = self.pid.step(dt, ref_position, ref_velocity, position, velocity, feedforward)
        self._remember_command(now_s, terms.command)
        return ControlOutput(now_s, status, ref_position, position, terms)

    # --- faults -------------------------------------------------------------------

    def _controlled_stop_on_model(self, now_s: float, dt: float) -> ControlOutput:
        """Category 2 while readings are missing: bring the reference to rest within
        the torque limit and hold, acting on the arm model's prediction under the
        torques this controller issued (the Kalman filter's predict step, open loop)."""
        self._needs_reacquire = True
        if self._estimate is None:
            self._estimate = (self._measurement[0], self._measurement[1], now_s)
        position, velocity, estimate_s = self._estimate
        if self.dynamics is not None and now_s > estimate_s:
            position, velocity = self.dynamics.predict(position, velocity, self._last_command(), now_s - estimate_s)
        self._estimate = (position, velocity, now_s)
        if self._sensor_stop is None:
            # From where the reference is now (no jump in it), then to rest.
            start_position, start_velocity, _, _ = self._reference_now(now_s, position)
            self._sensor_stop = ControlledStop(now_s, start_position, start_velocity, self.config.stop_deceleration)
        ref_position, ref_velocity, ref_acceleration = self._sensor_stop.at(now_s)
        self._last_reference, self._last_reference_s = (ref_position, ref_velocity, ref_acceleration), now_s
        return self._law(now_s, dt, Status.WATCHDOG, position, velocity, ref_position, ref_velocity,
                         ref_acceleration)

    def _reacquire(self, now_s: float) -> bool:
        """A fault has cleared (or the loop is starting): start again from the
        measurement (estimator and integral re-initialised) and lead the arm from
        where it is onto the trajectory. False while there is no fresh
        reference to lead it onto (the caller holds the arm meanwhile)."""
        self._sensor_stop = None
        self.pid.reset()
        if self.estimator is not None:
            self.estimator.reset()
        self._filtered_stamp_s = -np.inf
        self._estimate = None
        if self._reference is None or not self._planner_spoke or not self._trajectory_now(now_s)[3]:
            return False
        self._needs_reacquire = False
        self._hold_position = None
        position, velocity = self._measurement
        if self.config.latency_compensation:
            # the reading's age, on the model alone: the last commands are no guide after a fault
            age = float(np.clip(now_s - self._measurement_stamp_s, 0.0, _MAX_EXTRAPOLATION_S))
            position = position + velocity * age
        ref_position, ref_velocity, _, _ = self._trajectory_now(now_s)
        self._reference_stop = None
        self._blend = Blend.starting(now_s, position - ref_position, velocity - ref_velocity,
                                     self.config.reacquire_acceleration)
        return True

    def _last_command(self) -> np.ndarray:
        return self._commands[-1][1] if self._commands else np.zeros(self.joint_count)

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
