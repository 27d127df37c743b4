"""The joint controller the ``pid_controller`` node runs, once per tick (:meth:`JointController.update`): the inputs'
health (:mod:`.supervision`), the arm's state at the tick (:mod:`.tick_state`), the reference at the tick
(:mod:`.reference_in_force`), then the law in force (built in, or a user's :class:`ContainedLaw`, called alike) or a
stop: one torque command."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from robot_controller.core.controller.config import ControllerConfig, law_config
from robot_controller.core.controller.inertia_adaptation import InertiaAdaptation
from robot_controller.core.controller.law_build import arm_of, builtin_law, hold_to_limits, plugin_law
from robot_controller.core.controller.reference_in_force import ReferenceAtTick
from robot_controller.core.controller.supervision import (
    ControlOutput,
    LatencyGuard,
    LatencyState,
    PositionNoise,
    Readings,
    ReferenceSource,
    Status,
    TickClock,
    age_refusal,
    check_health,
    delay_margin_periods,
)
from robot_controller.core.controller.tick_state import MAX_EXTRAPOLATION_S, StateAtTick, make_estimator, make_state
from robot_controller.core.errors import ConfigError
from robot_controller.core.estimation import JointKalmanFilter
from robot_controller.core.laws import (
    BuiltinLaw,
    ContainedLaw,
    FeedforwardMode,
    LawFault,
    Pid,
    PidConfig,
    PidTerms,
    Reference,
    State,
    registry,
)
from robot_controller.core.model import ArmDynamics

# How long the arm is held at rest after a controlled stop before the torque goes off and the brakes hold (category 2,
# then 1), and the status then: on the built-in law after a plugin law failed; on the model (open loop it drifts: held
# briefly) while readings are missing or the loop is late.
LAW_FAULT_HOLD_S = 0.5
LATE_HOLD_S = 0.1
SENSOR_STOP_HOLD_S = 0.1
STOPS = {
    ReferenceSource.LAW_STOP: (LAW_FAULT_HOLD_S, Status.LAW_STOPPED),
    ReferenceSource.LATE_STOP: (LATE_HOLD_S, Status.LATE_STOPPED),
    ReferenceSource.SENSOR_STOP: (SENSOR_STOP_HOLD_S, Status.SENSOR_LOST),
}


class JointController:
    """``law_clock``: wall-time seconds, to hold a plugin law to its ``law_budget_s`` (None: unchecked, as in the
    in-process loops), less what ``law_run_wait`` says the law's thread waited for a CPU (None: unknown).
    ``latency_guard``: stop the motion while the readings' and commands' delay is past the delay margin."""

    def __init__(
        self,
        config: ControllerConfig,
        joint_count: int,
        dynamics: ArmDynamics | None = None,
        law_clock: Callable[[], float] | None = None,
        latency_guard: bool = False,
        law_run_wait: Callable[[], float] | None = None,
    ) -> None:
        if config.feedforward is not FeedforwardMode.NONE and dynamics is None:
            raise ConfigError("feedforward: needs the arm model (urdf_path)")
        self.config = config
        self.joint_count = joint_count
        self.dynamics = dynamics
        if not config.plugin_law and not issubclass(registry.resolve(config.controller_type), BuiltinLaw):
            raise ConfigError(f"controller_type: {config.controller_type!r} is registered to a law not built in")
        #: the built-in law: the law in force, or under a plugin law the one that stops the arm if it fails
        self.stop_law = self._builtin(config)
        self._law_clocks = (law_clock, law_run_wait)
        self.law = self._plugin(config) if config.plugin_law else self.stop_law  #: the law in force
        self._state = make_state(config, dynamics, joint_count, lambda: self.pid, lambda: self.config)
        #: the inertia adaptation (its ``armature``, kg·m² per joint; ``notes()``: its gain changes), or None
        self.inertia: InertiaAdaptation | None = self._state.inertia
        self._reference = ReferenceAtTick(joint_count)
        self._readings = Readings()
        self._clock = TickClock()
        self._halted = False
        self._braked = False
        self._gap_braked = False  # the world went on without this controller (it waits no more), so its drive braked
        self._latency_guard = latency_guard
        self._latency = self._new_latency_guard(config) if latency_guard else None
        self._rest_s: dict[ReferenceSource, float] = {}  # when each controlled stop came to rest
        #: the latency guard's latest verdict (None without a guard, or before its first tick)
        self.latency: LatencyState | None = None

    def _builtin(self, config: ControllerConfig) -> BuiltinLaw:
        return builtin_law(config, arm_of(config, self.dynamics, self.joint_count))

    def _plugin(self, config: ControllerConfig) -> ContainedLaw:
        return plugin_law(config, arm_of(config, self.dynamics, self.joint_count), *self._law_clocks)

    @property
    def plugin(self) -> ContainedLaw | None:
        """The user's law in force, or None under a built-in law."""
        return self.law if self.law is not self.stop_law else None

    @property
    def pid(self) -> Pid:
        """The built-in law's PID."""
        return self.stop_law.pid

    @property
    def law_fault(self) -> LawFault | None:
        """What the plugin law did wrong, once it has (it is then never called again)."""
        law = self.law
        return None if law is self.stop_law else law.fault

    @property
    def estimator(self) -> JointKalmanFilter | None:
        """The Kalman filter on the readings, or None."""
        return self._state.kalman

    @property
    def reference_period_s(self) -> float | None:
        """The planner's period (s), learned from consecutive sample times."""
        return self._reference.planner.period_s

    @property
    def gains(self) -> PidConfig:
        """The built-in law's gains in force (for LQR, the designed ones; with the inertia adaptation, scaled)."""
        return self.pid.config

    def law_in_force(self) -> str:
        """One line: the law and its gains in force (LQR: the design replaces kp/ki/kd; the inertia adaptation's
        factors); for a plugin law, its name and parameters, and the built-in law its stops run on."""
        sigma = self.config.estimator.disturbance_noise_std if self.config.observes_disturbance else None
        observer = "" if sigma is None else f", disturbance observer (σ {sigma:g} N·m/√s, estimate subtracted)"
        builtin = self.stop_law.describe(observer) + ("" if self.inertia is None else self.inertia.describe())
        said = builtin if self.plugin is None else f"{self.plugin.describe()}; stops on the built-in {builtin}"
        lag_s = self.config.model_drive_lag_s  # (whichever law: its torque is what the drive applies)
        return said + (f"; the drive's lag of {lag_s * 1e3:.3g} ms inverted" if lag_s > 0 else "")

    def delay_margin_periods(self) -> int | None:
        """Whole control periods of unaccounted delay the built-in law's feedback survives on the worst joint
        (:func:`delay_margin_periods`); None without the arm model, and for a plugin law (its feedback is unknown)."""
        if self.plugin is not None:
            return None
        learnt = None if self.inertia is None else self.inertia.inertia  # adapted gains: judged on the inertia learnt
        return delay_margin_periods(self.gains, self.dynamics, self.joint_count, self.config, learnt)

    def _new_latency_guard(self, config: ControllerConfig) -> LatencyGuard | None:
        """The guard for the gains in force; compensation accounts for MAX_EXTRAPOLATION_S of a reading's age."""
        compensated_s = MAX_EXTRAPOLATION_S if config.latency_compensation else 0.0
        return LatencyGuard.for_margin(self.delay_margin_periods(), config.control_period_s, compensated_s)

    def set_config(self, config: ControllerConfig) -> None:
        """New gains and options, applied bumplessly from the next tick."""
        if config.feedforward is not FeedforwardMode.NONE and self.dynamics is None:
            raise ConfigError("feedforward: needs the arm model (urdf_path)")
        own = config.plugin_law or self.config.plugin_law
        if config.controller_type != self.config.controller_type and own:
            raise ConfigError("controller_type: a law of one's own is chosen when the controller starts; restart it")
        law_config(config, self.dynamics, self.joint_count)  # refuses a bad design first
        if self.plugin is not None:
            if config.law_parameters != self.config.law_parameters:
                self.plugin.set_params(config.law_parameters)
            hold_to_limits(self.plugin, config)
        if config.estimator != self.config.estimator or config.observes_disturbance != self.config.observes_disturbance:
            self._state.kalman = make_estimator(config, self.dynamics, self.joint_count)
        elif self._state.kalman is not None:
            limit = np.asarray(config.pid.output_limit, float)
            self._state.kalman.disturbance_limit = np.broadcast_to(limit, (self.joint_count,)).copy()
        builtin_in_force = self.law is self.stop_law
        self.config = config
        if config.builtin_law != self.stop_law.kind:
            self.stop_law = self._builtin(config)
        else:
            self.stop_law.set_params(config.law_params())
        if builtin_in_force:
            self.law = self.stop_law
        if self._latency_guard:  # the margin of the new gains
            guard = self._new_latency_guard(config)
            if guard is not None and self._latency is not None:
                self._latency.tolerated_s, self._latency.compensated_s = guard.tolerated_s, guard.compensated_s
            else:
                self._latency = guard

    # --- inputs -----------------------------------------------------------------------

    def set_reference(
        self,
        received_s: float,
        position: np.ndarray,
        velocity: np.ndarray,
        acceleration: np.ndarray,
        sample_time_s: float | None = None,
    ) -> None:
        """A new reference sample; its time base is ``sample_time_s`` when the planner sent one, else its arrival."""
        self._reference.planner.receive(received_s, position, velocity, acceleration, sample_time_s)

    def has_reference(self) -> bool:
        """Whether any reference sample has arrived."""
        return self._reference.planner.spoke

    def reference_ready(self, tick_s: float) -> bool:
        """Whether every reference sample due by ``tick_s`` is in (where the world waits for each command)."""
        return self._reference.planner.ready(tick_s)

    @property
    def measurement_stamp_s(self) -> float:
        return self._readings.stamp_s

    def set_measurement(
        self,
        stamp_s: float,
        received_s: float,
        position: np.ndarray,
        velocity: np.ndarray,
        noise: PositionNoise | None = None,
    ) -> str | None:
        """Take a reading stamped ``stamp_s`` that arrived at ``received_s`` (``noise``: what a camera's says of its
        own errors, its velocity unmeasured); returns why it was refused (it is then no sign of life for the watchdog
        either), or None."""
        max_age_s = self.config.max_reading_age_s
        refused = self._readings.accept(stamp_s, received_s, position, velocity, max_age_s, noise)
        age_s = received_s - stamp_s
        if self._latency is not None and (refused is None or age_s > 0):
            # A reading refused as too old is weighed too: those kept are at most max_reading_age_s old, all of which
            # the latency compensation accounts for.
            self._latency.reading(age_s)
        return refused

    def set_second_measurement(
        self, stamp_s: float, received_s: float, position: np.ndarray, noise: PositionNoise
    ) -> str | None:
        """A second sensor's reading of the positions (a camera's beside the encoder): fused by the filter at the
        next tick; returns why it was refused (too old, or no filter to fuse it), or None."""
        if refused := age_refusal(stamp_s, received_s, self.config.max_reading_age_s):
            return refused
        if self._state.kalman is None:
            return "a second sensor is fused by the filter: set estimator kalman"
        self._state.take_second(stamp_s, position, noise)
        return None

    def command_delay(self, receipt_s: float, delay_s: float) -> None:
        """A command reached the drive ``delay_s`` after its tick (the drive's receipt at ``receipt_s``)."""
        if self._latency is not None:
            self._latency.command(receipt_s, delay_s)

    @property
    def has_measurement(self) -> bool:
        return self._readings.latest is not None

    def restart_from_arm(self) -> None:
        """The arm was moved by something else (a guard's brake): at the next tick, start again from the measurement
        (estimator, integral) and lead the arm from there onto the reference."""
        self._reference.request_reacquire()

    def halt(self, halted: bool) -> None:
        """An e-stop holds the drive: command nothing; when it is released, re-acquire from the measurement."""
        if halted and not self._halted:
            self._reference.request_reacquire()
        self._halted = halted

    def brakes(self, engaged: bool) -> None:
        """The drive reports its brakes. While they hold, start again from the measurement every
        tick (no integral winds up); their release asks for one more start, since a reading taken
        while they held shows the brake's work, which the filter's model knows nothing of."""
        if self._braked and not engaged:
            self._reference.request_reacquire()
        self._braked = engaged

    # --- the tick ---------------------------------------------------------------------

    def update(self, now_s: float) -> ControlOutput:
        """Compute the command for the tick at ``now_s`` seconds."""
        config = self.config
        tick = self._clock.advance(now_s, config.control_period_s)
        if tick.paused:  # this controller was not running: the world moved on
            self._reference.request_reacquire()
            self._readings.excuse_pause(tick.gap_s, config.control_period_s, config.max_reading_age_s)
            self._gap_braked = config.world_waits  # until a command releases them: no stop on a model that moved on
        self._reference.planner.advance_to(now_s)  # the samples that were sent ahead of their time
        braked = self._braked or self._gap_braked
        health = check_health(self._readings, now_s, self._halted, braked, config)
        if health.restart:
            self._reference.request_reacquire()
        if not health.status.commanding:
            return self._no_command(now_s, health.status)
        if self.law_fault is not None:
            return self._stop(now_s, ReferenceSource.LAW_STOP, on_model=health.status is Status.WATCHDOG)
        # Late first: its stop runs open loop on the model, readings or not (a late link delivers
        # readings in gaps, and each gap would begin another stop on the model).
        if self._latency is not None:
            self.latency = self._latency.update(now_s)
            if self.latency.cleared:  # on time again: lead the arm back onto the trajectory
                self._rest_s.pop(ReferenceSource.LATE_STOP, None)
                self._reference.request_reacquire()
            if self.latency.late:
                return self._stop(now_s, ReferenceSource.LATE_STOP)
        if health.status is Status.WATCHDOG:
            if braked:  # the brakes hold the arm already; a command would release them
                return self._no_command(now_s, Status.SENSOR_LOST)
            return self._stop(now_s, ReferenceSource.SENSOR_STOP)
        self._rest_s.pop(ReferenceSource.SENSOR_STOP, None)
        if self._reference.reacquire_pending:
            self._restart_from_measurement(now_s, braked)
        position, velocity = self._state.held(now_s, self._readings) if braked else self._estimate_at_tick(now_s)
        reference = self._reference.at_tick(now_s, position, config)
        return self._apply_law(now_s, position, velocity, reference)

    def _estimate_at_tick(self, now_s: float) -> tuple[np.ndarray, np.ndarray]:
        return self._state.at_tick(now_s, self._readings, self.config.latency_compensation)

    def _restart_from_measurement(self, now_s: float, braked: bool = False) -> None:
        """A fault has cleared (or the loop is starting): forget the law's and the filter's state, and lead the arm
        from the reading (``braked``: held there) onto a fresh trajectory (none: hold it, and try again next tick)."""
        self._state.reset()
        compensate = self.config.latency_compensation
        position, velocity = StateAtTick.reading_alone(now_s, self._readings, compensate, held=braked)
        state = self._law_state(position, velocity, None)
        if self.plugin is not None:
            self.plugin.reset(state, now_s)
        self.stop_law.reset(state)
        self._reference.try_reacquire(now_s, position, velocity, self.config)

    def _stop(self, now_s: float, source: ReferenceSource, on_model: bool = True) -> ControlOutput:
        """The controlled stop from ``source`` (:data:`STOPS`), the law on the model's prediction under its own
        torques (``on_model``: open loop, which a delay cannot make oscillate) or on the estimate, held at rest
        for the stop's hold, then no commands (category 1: the drive's timeout brakes the arm)."""
        hold_s, stopped = STOPS[source]
        rest_s = self._rest_s.get(source)
        if rest_s is not None and now_s - rest_s >= hold_s:
            return self._no_command(now_s, stopped)
        if on_model:
            position, velocity = self._state.coast(now_s, self._readings)
        else:
            position, velocity = self._estimate_at_tick(now_s)
        reference = self._reference.stop(now_s, source, position, self.config)
        if rest_s is None and self._reference.stop_at_rest(source, now_s):
            self._rest_s[source] = now_s
        return self._apply_law(now_s, position, velocity, reference)

    def _apply_law(
        self, now_s: float, position: np.ndarray, velocity: np.ndarray, reference: Reference
    ) -> ControlOutput:
        """The law in force's torque, remembered for the estimator; a plugin law that fails on this tick is
        answered at once with the stop on the built-in law."""
        disturbance = self._state.disturbance()
        state = self._law_state(position, velocity, disturbance)
        stop_law, law = self.stop_law, self.law
        if law is not stop_law and law.fault is not None:
            law = stop_law
        law.update(now_s, state, reference)
        if law is not stop_law and law.fault is not None:  # the user's law failed on this tick
            law = stop_law
            law.reset(state)
            reference = self._reference.stop(now_s, ReferenceSource.LAW_STOP, position, self.config, reference)
            law.update(now_s, state, reference)
        self._gap_braked = False  # this command releases the drive's brakes
        if law is stop_law:  # the PID's own terms, as they are
            terms, law_terms = law.last_terms, None
        else:
            t = law.terms()
            terms = PidTerms(t["command"], t["p"], t["i"], t["d"], t["feedforward"], t["saturated"])
            law_terms = {name: t[name] for name in law.extra_terms}
        if (command := self._state.issue(now_s, terms.command, self.config.control_period_s)) is not terms.command:
            terms = replace(terms, command=command)  # (the drive's lag inverted: the law's torque is what acts)
        status, source = self._reference.status, self._reference.source
        return ControlOutput(now_s, status, reference.position, position, terms, source, disturbance, law_terms)

    def _law_state(self, position: np.ndarray, velocity: np.ndarray, disturbance: np.ndarray | None) -> State:
        """What a law is told of the arm: the estimate, the latest reading and the observer's torque."""
        measured = self._readings.latest if self._readings.latest is not None else (position, velocity)
        return State(position, velocity, *measured, np.zeros(self.joint_count) if disturbance is None else disturbance)

    def _no_command(self, now_s: float, status: Status) -> ControlOutput:
        """Zero torque, remembered as issued; reported at the arm's last known position (zero before any)."""
        if status is Status.NO_MEASUREMENT:
            position = np.zeros(self.joint_count)
        elif status is Status.STOPPED:
            position = self._readings.latest[0]
        else:  # SENSOR_LOST, LAW_STOPPED, LATE_STOPPED: the stop is over; torque off, the brake holds
            position = self._state.last_position(self._readings)
        zeros = np.zeros(self.joint_count)
        self._state.drive_stopped(now_s)
        # Nothing commanded, nothing to learn from: the filter starts afresh (d̂ = 0) with the
        # re-acquisition that every way back to commanding goes through.
        self._state.reset_filter()
        terms = PidTerms(zeros, zeros, zeros, zeros, zeros, np.zeros(self.joint_count, dtype=bool))
        position = np.asarray(position, float)
        return ControlOutput(now_s, status, position, position, terms, ReferenceSource.NONE)
