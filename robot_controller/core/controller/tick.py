"""The steps of :meth:`JointController.update <robot_controller.core.controller.controller.JointController.update>`
(:class:`TickSteps`, a part of the controller): advance the tick clock, check the inputs'
health, start again from the reading after a fault, estimate the state and take the
reference at the tick, run the law; and the stops that answer a fault (readings missing,
a late loop, a plugin law that failed, with the latency guard that finds the loop late)
and the ticks that command nothing."""

from __future__ import annotations

import numpy as np

from robot_controller.core.controller.config import ControllerConfig
from robot_controller.core.controller.health import Health, Tick, check_health
from robot_controller.core.controller.latency import LatencyGuard
from robot_controller.core.controller.output import ControlOutput, ReferenceSource, Status
from robot_controller.core.controller.reference_at_tick import Reference
from robot_controller.core.controller.tick_state import MAX_EXTRAPOLATION_S, StateAtTick
from robot_controller.core.laws.containment import LawFault
from robot_controller.core.laws.pid import PidTerms

# After a plugin law fails, the arm is held at rest on the built-in law this long before the
# torque goes off and the brakes hold (category 2, then 1).
LAW_FAULT_HOLD_S = 0.5
# After the latency stop comes to rest, the arm is held on the model this long (short: open loop, it
# drifts under a late command path) before the torque goes off and the brakes hold (category 2, then 1),
# until the loop is on time again.
LATE_HOLD_S = 0.1
# After the stop for missing readings comes to rest, the same, for the same reason: held open loop
# until the sensor timeout (1 s), an arm above the horizontal (where gravity's torque falls as it
# rises: an unstable hold) drifted away from a hold 0.02 N·m off and swung 0.3-0.9 rad out of its
# band in 4 of 9 runs of a 1 s sensor freeze at the top of the sine.
SENSOR_STOP_HOLD_S = 0.1


class TickSteps:
    """The named steps of a tick and the fault stops of
    :class:`~robot_controller.core.controller.controller.JointController`."""

    def _advance_clock(self, now_s: float) -> Tick:
        """The period (s) the law integrates over this tick. A gap of more than
        REACQUIRE_GAP_PERIODS periods means this controller itself was not
        running: the world moved on, so re-acquire; if the pause was short, the
        readings it held back are on their way, so it is not the sensor's silence."""
        tick = self._clock.advance(now_s, self.config.control_period_s)
        if tick.paused:
            self._reference.request_reacquire()
            self._readings.excuse_pause(tick.gap_s, self.config.control_period_s, self.config.max_reading_age_s)
        return tick

    def _check_health(self, now_s: float) -> Health:
        """Readings, e-stop and brakes at ``now_s`` → a Status (see
        :func:`check_health`); a fault that let the arm move without this
        controller makes the reference start again from the measurement."""
        health = check_health(self._readings, now_s, self._halted, self._braked, self.config)
        if health.restart:
            self._reference.request_reacquire()
        return health

    def _restart_from_measurement(self, now_s: float) -> None:
        """A fault has cleared (or the loop is starting): forget the integral and
        the filter's state, and lead the arm from where the reading says it is
        onto the trajectory, if there is a fresh one (otherwise the reference
        holds the arm, and this is tried again next tick)."""
        self.pid.reset()
        self._state.reset()
        position, velocity = StateAtTick.reading_alone(now_s, self._readings, self.config.latency_compensation)
        if self.plugin is not None:
            self.plugin.reset(now_s, position, velocity, self._readings.latest)
        self._reference.try_reacquire(now_s, position, velocity, self.config)

    def _estimate_at_tick(self, now_s: float) -> tuple[np.ndarray, np.ndarray]:
        """The arm's ``(position rad, velocity rad/s)`` at ``now_s``: the reading,
        filtered, advanced from its stamp to the tick (latency compensation)."""
        return self._state.at_tick(now_s, self._readings, self.config.latency_compensation)

    def _reference_at_tick(self, now_s: float, position: np.ndarray) -> Reference:
        """The reference for this tick and its source: the trajectory (held or
        extrapolated), a hold, a controlled stop if the planner went quiet, or
        the blend back onto the trajectory after a fault."""
        return self._reference.at_tick(now_s, position, self.config)

    def _make_latency_guard(self, config: ControllerConfig) -> LatencyGuard | None:
        """The guard for the gains in ``config`` (None when their delay margin is not known: a law of
        one's own, no arm model)."""
        margin = self.delay_margin_periods()
        if margin is None:
            return None
        compensated_s = MAX_EXTRAPOLATION_S if config.latency_compensation else 0.0
        return LatencyGuard(margin * config.control_period_s, compensated_s)

    def _late(self, now_s: float) -> bool:
        """The latency guard's verdict; when it clears, the arm is led back onto the trajectory."""
        self.latency = self._latency.update(now_s)
        if self.latency.late:
            self._was_late = True
        elif self._was_late:
            self._was_late, self._late_rest_s = False, None
            self._reference.request_reacquire()
        return self.latency.late

    def _stop_when_late(self, now_s: float, dt_s: float) -> ControlOutput:
        """While the loop is later than its gains survive, feedback through that delay
        oscillates (a hold on the late readings swung the arm ±0.3 rad at the torque limit
        with commands 4 periods late, twice the margin). So, as when readings are missing:
        category 2, the reference brought to rest within the torque limit with the law on
        the arm model's prediction under its own torques (open loop: a delay cannot make it
        oscillate), held LATE_HOLD_S at rest, then no commands (category 1: the drive's
        timeout brakes the arm) until the loop is on time again. (Holding on the model for
        longer let the arm drift 0.2 rad in 0.5 s under commands 40 ms late.)"""
        if self._late_rest_s is not None and now_s - self._late_rest_s >= LATE_HOLD_S:
            return self._no_command(now_s, Status.LATE_STOPPED)
        position, velocity = self._state.coast(now_s, self._readings)
        reference = self._reference.late_stop(now_s, position, self.config)
        if self._late_rest_s is None and self._reference.late_stop_at_rest(now_s):
            self._late_rest_s = now_s
        return self._apply_law(now_s, dt_s, position, velocity, reference)

    def _stop_on_model(self, now_s: float, dt_s: float) -> ControlOutput:
        """Category 2 while readings are missing: bring the reference to rest
        within the torque limit, acting on the arm model's prediction under the
        torques this controller issued, hold it SENSOR_STOP_HOLD_S, then command
        nothing (category 1: the drive's timeout brakes the arm) until readings return."""
        if self._sensor_rest_s is not None and now_s - self._sensor_rest_s >= SENSOR_STOP_HOLD_S:
            return self._no_command(now_s, Status.SENSOR_LOST)
        if self._braked:
            # The brakes hold the arm already: nothing to stop, and a command would release them.
            return self._no_command(now_s, Status.SENSOR_LOST)
        position, velocity = self._state.coast(now_s, self._readings)
        reference = self._reference.sensor_stop(now_s, position, self.config)
        if self._sensor_rest_s is None and self._reference.sensor_stop_at_rest(now_s):
            self._sensor_rest_s = now_s
        return self._apply_law(now_s, dt_s, position, velocity, reference)

    def _apply_law(
        self, now_s: float, dt_s: float, position: np.ndarray, velocity: np.ndarray, reference: Reference
    ) -> ControlOutput:
        """The law's torque within the torque limit (a plugin law's, or the built-in
        law's feedback plus feedforward); the command is remembered for the
        estimator and the model's predictions. A plugin law that fails here is
        answered at once: this tick already starts the stop on the built-in law."""
        disturbance = self._state.disturbance()
        law_terms = None
        if self.plugin is not None and self.plugin.fault is None:
            outcome = self.plugin.step(now_s, dt_s, position, velocity, self._readings.latest, reference, disturbance)
            if isinstance(outcome, LawFault):
                self.pid.reset()
                reference = self._reference.law_stop(now_s, reference, self.config)
                terms = self.builtin.step(dt_s, position, velocity, reference, disturbance)
            else:
                terms, law_terms = outcome
        else:
            terms = self.builtin.step(dt_s, position, velocity, reference, disturbance)
        self._state.remember_command(now_s, terms.command)
        return ControlOutput(
            now_s, reference.status, reference.position, position, terms, reference.source, disturbance, law_terms
        )

    def _stop_after_law_fault(self, now_s: float, dt_s: float, status: Status) -> ControlOutput:
        """The plugin law failed: the built-in law brings the reference to rest
        (category 2, on the model's estimate while readings are missing), holds
        the arm there for LAW_FAULT_HOLD_S, then commands nothing: the drive's
        command timeout takes the torque off and the brakes hold (category 1)."""
        if self._law_fault_rest_s is not None and now_s - self._law_fault_rest_s >= LAW_FAULT_HOLD_S:
            return self._no_command(now_s, Status.LAW_STOPPED)
        if status is Status.WATCHDOG:
            position, velocity = self._state.coast(now_s, self._readings)
        else:
            position, velocity = self._estimate_at_tick(now_s)
        reference = self._reference.law_stop(now_s, None, self.config)
        if self._law_fault_rest_s is None and self._reference.law_stop_at_rest(now_s):
            self._law_fault_rest_s = now_s
        return self._apply_law(now_s, dt_s, position, velocity, reference)

    def _no_command(self, now_s: float, status: Status) -> ControlOutput:
        """A tick that commands nothing (no reading yet, e-stop, sensor lost):
        zero torque, remembered as issued; the reported reference and
        measurement are the arm's last known position (zero before any)."""
        if status is Status.NO_MEASUREMENT:
            position = np.zeros(self.joint_count)
        elif status is Status.STOPPED:
            position = self._readings.latest[0]
        else:  # SENSOR_LOST, LAW_STOPPED: the controlled stop is over; torque off, the drive's brake holds
            position = self._state.last_position(self._readings)
        zeros = np.zeros(self.joint_count)
        self._state.remember_command(now_s, zeros)
        # Nothing commanded, nothing to learn from: the arm is braked or
        # unattended, and a disturbance estimate kept (or grown) meanwhile would
        # be applied on the way back. The filter starts afresh (d̂ = 0) with the
        # re-acquisition that every way back to commanding goes through.
        self._state.reset_filter()
        terms = PidTerms(zeros, zeros, zeros, zeros, zeros, np.zeros(self.joint_count, dtype=bool))
        position = np.asarray(position, float)
        return ControlOutput(now_s, status, position, position, terms, ReferenceSource.NONE)
