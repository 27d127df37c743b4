"""The joint controller the ``pid_controller`` node runs, called once per tick.

It keeps the latest reference and reading with the times they arrived and,
on :meth:`JointController.update`, turns them into one torque command in a
fixed sequence of named steps: advance the tick clock, check the inputs'
health, estimate the arm's state at the tick, take the reference at the
tick, run the law. The steps' workings live in their own modules:
:mod:`~robot_controller.core.controller.health`, :mod:`~robot_controller.core.controller.tick_state`,
:mod:`~robot_controller.core.controller.reference_at_tick`, :mod:`~robot_controller.core.laws.gains`;
the steps themselves and the stops that answer a fault, in
:mod:`~robot_controller.core.controller.tick`.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from robot_controller.core.controller.config import ControllerConfig
from robot_controller.core.controller.health import REACQUIRE_GAP_PERIODS, Readings, TickClock
from robot_controller.core.controller.latency import LatencyGuard, LatencyState
from robot_controller.core.controller.output import ControlOutput, ReferenceSource, Status
from robot_controller.core.controller.reference_at_tick import ReferenceAtTick
from robot_controller.core.controller.setpoint import REFERENCE_TIMEOUT_PERIODS
from robot_controller.core.controller.tick import TickSteps
from robot_controller.core.controller.tick_state import StateAtTick
from robot_controller.core.errors import ConfigError
from robot_controller.core.estimation.estimator import JointKalmanFilter
from robot_controller.core.laws import registry
from robot_controller.core.laws.builtin import BuiltinLaw
from robot_controller.core.laws.containment import LawFault
from robot_controller.core.laws.feedforward import FeedforwardMode
from robot_controller.core.laws.gains import (
    delay_margin_periods,
    describe_law,
    design_inertia,
    law_config,
    observer_torque_scale,
)
from robot_controller.core.laws.pid import Pid, PidConfig
from robot_controller.core.laws.plugin import PluginLaw
from robot_controller.core.model import ArmDynamics

__all__ = [
    "REACQUIRE_GAP_PERIODS",
    "REFERENCE_TIMEOUT_PERIODS",
    "ControlOutput",
    "ControllerConfig",
    "JointController",
    "ReferenceSource",
    "Status",
    "law_config",
]


class JointController(TickSteps):
    """``law_clock``: a function giving seconds of wall time, to hold a plugin law to
    its ``law_budget_s`` (None: its time is not checked, as in the in-process loops).
    ``latency_guard``: stop the motion while the readings' and commands' delay is
    past the delay margin (:mod:`~robot_controller.core.controller.latency`; the node's wall
    clock: in lockstep and the in-process loops nothing is late)."""

    def __init__(
        self,
        config: ControllerConfig,
        joint_count: int,
        dynamics: ArmDynamics | None = None,
        law_clock: Callable[[], float] | None = None,
        latency_guard: bool = False,
    ) -> None:
        if config.feedforward is not FeedforwardMode.NONE and dynamics is None:
            raise ConfigError("feedforward: needs the arm model (urdf_path)")
        self.config = config
        self.joint_count = joint_count
        self.dynamics = dynamics
        # The built-in law: the law itself, or under a plugin law the one that stops the arm if it fails.
        self.builtin = BuiltinLaw.of_kind(config.builtin_law, config, dynamics, joint_count)
        if not config.plugin_law and not issubclass(registry.resolve(config.controller_type), BuiltinLaw):
            raise ConfigError(f"controller_type: {config.controller_type!r} is registered to a law not built in")
        self.plugin = PluginLaw.build(config, dynamics, joint_count, law_clock) if config.plugin_law else None
        self._law_fault_rest_s: float | None = None  # when the stop after a law fault came to rest
        self._state = StateAtTick(joint_count, dynamics, self._make_estimator(config))
        self._reference = ReferenceAtTick(joint_count)
        self._readings = Readings()
        self._clock = TickClock()
        self._halted = False
        self._braked = False
        self._latency_guard = latency_guard
        self._latency: LatencyGuard | None = self._make_latency_guard(config) if latency_guard else None
        self._was_late = False
        self._late_rest_s: float | None = None  # when the latency stop came to rest
        self._sensor_rest_s: float | None = None  # when the stop for missing readings came to rest
        #: the latency guard's latest verdict (None without a guard, or before its first tick)
        self.latency: LatencyState | None = None

    def _make_estimator(self, config: ControllerConfig) -> JointKalmanFilter | None:
        if config.estimator is None:
            return None
        if self.dynamics is None:
            raise ConfigError("estimator kalman: needs the arm model (urdf_path)")
        return JointKalmanFilter(
            config.estimator,
            self.joint_count,
            self.dynamics.predict,
            jacobian=getattr(self.dynamics, "step_jacobian", None),
            estimate_disturbance=config.observes_disturbance,
            mass_matrix=self.dynamics.mass_matrix,
            one_joint=getattr(self.dynamics, "one_joint", None),
            disturbance_limit=config.pid.output_limit,
            torque_scale=observer_torque_scale(
                design_inertia(self.dynamics, self.joint_count, config.design_position), config.reference_inertia
            ),
        )

    @property
    def pid(self) -> Pid:
        """The built-in law's PID (for a plugin law, the one its stops run on)."""
        return self.builtin.pid

    @property
    def law_fault(self) -> LawFault | None:
        """What the plugin law did wrong, once it has (it is then never called again)."""
        return None if self.plugin is None else self.plugin.fault

    @property
    def estimator(self) -> JointKalmanFilter | None:
        """The Kalman filter on the readings, or None."""
        return self._state.kalman

    @property
    def reference_period_s(self) -> float | None:
        """The planner's period (s), learned from consecutive sample times."""
        return self._reference.planner.period_s

    # --- the law in force -------------------------------------------------------------

    @property
    def gains(self) -> PidConfig:
        """The gains in force (for LQR, the designed ones)."""
        return self.pid.config

    def law_in_force(self) -> str:
        """One line saying which law runs and with which gains, e.g. ``"LQR (q=[...],
        r=10, ...): Kp=[29.7] N·m/rad, ...; the kp/ki/kd parameters are unused"``
        or ``"PID: Kp=[50] N·m/rad, ..."``: in LQR mode the design replaces
        kp/ki/kd, which would otherwise be silently ignored. For a plugin law: its
        name and parameters, and the built-in law its stops run on."""
        if self.plugin is not None:
            return f"{self.plugin.describe()}; stops on the built-in {describe_law(self.config, self.gains)}"
        return describe_law(self.config, self.gains)

    def delay_margin_periods(self) -> int | None:
        """Whole control periods of delay nobody accounts for (a late command, a
        reading stamped on arrival) the feedback survives, on the worst joint:
        the gains in force on the arm linearised at rest, as
        :func:`lqr.delay_margin_periods` reckons it. None without the arm model.

        Delay the stamps show is compensated on the model (``latency_compensation``);
        this is the margin for the rest, e.g. the controller → motor → simulator path.
        With the disturbance observer, the loop through the filter and the
        observer (:func:`law.observer_delay_margin_periods`): a fast observer
        takes a late reading for a push and spends the margin. None for a plugin
        law: its feedback is not known here.
        """
        if self.plugin is not None:
            return None
        return delay_margin_periods(
            self.gains,
            self.dynamics,
            self.joint_count,
            self.config.control_period_s,
            self.config.estimator,
            self.config.observes_disturbance,
            self.config.design_position,
            self.config.reference_inertia,
        )

    def set_config(self, config: ControllerConfig) -> None:
        """New gains and options, applied bumplessly from the next tick."""
        if config.feedforward is not FeedforwardMode.NONE and self.dynamics is None:
            raise ConfigError("feedforward: needs the arm model (urdf_path)")
        if config.controller_type != self.config.controller_type and (config.plugin_law or self.config.plugin_law):
            raise ConfigError(
                "controller_type: a law of one's own is chosen when the controller starts; restart it to change"
            )
        law_config(config, self.dynamics, self.joint_count, config.builtin_law)  # refuses a bad design first
        if self.plugin is not None:
            self.plugin.set_params(config)
        if config.estimator != self.config.estimator or config.observes_disturbance != self.config.observes_disturbance:
            self._state.kalman = self._make_estimator(config)
        elif self._state.kalman is not None:
            self._state.kalman.disturbance_limit = np.broadcast_to(
                np.asarray(config.pid.output_limit, float), (self.joint_count,)
            ).copy()
        self.config = config
        if config.builtin_law != self.builtin.kind:
            self.builtin = BuiltinLaw.of_kind(config.builtin_law, config, self.dynamics, self.joint_count)
        else:
            self.builtin.set_config(config)
        if self._latency_guard:  # the margin of the new gains
            guard = self._make_latency_guard(config)
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
        """A new reference sample. Its time base is ``sample_time_s`` when the
        planner sent one, otherwise the time it arrived."""
        self._reference.planner.receive(received_s, position, velocity, acceleration, sample_time_s)

    def has_reference(self) -> bool:
        """Whether any reference sample has arrived."""
        return self._reference.planner.spoke

    def reference_ready(self, tick_s: float) -> bool:
        """Whether every reference sample due by ``tick_s`` is in (lockstep):
        the latest is at least as new as the tick, or the next is not due yet."""
        return self._reference.planner.ready(tick_s)

    @property
    def measurement_stamp_s(self) -> float:
        return self._readings.stamp_s

    def set_measurement(
        self, stamp_s: float, received_s: float, position: np.ndarray, velocity: np.ndarray
    ) -> str | None:
        """Take a reading stamped ``stamp_s`` that arrived at ``received_s``.

        Returns why it was refused (it is then not a sign of life for the
        watchdog either), or None.
        """
        refused = self._readings.accept(stamp_s, received_s, position, velocity, self.config.max_reading_age_s)
        age_s = received_s - stamp_s
        if self._latency is not None and (refused is None or age_s > 0):
            # One refused as too old is the plainest sign of a late loop: weighed too. (Left out,
            # the readings' part of the delay could never pass the margin: those kept are at most
            # max_reading_age_s old, all of which the latency compensation accounts for.)
            self._latency.reading(age_s)
        return refused

    def command_delay(self, receipt_s: float, delay_s: float) -> None:
        """A command of this controller's reached the drive ``delay_s`` seconds after its
        tick (the drive's receipt at ``receipt_s``): the latency guard weighs it."""
        if self._latency is not None:
            self._latency.command(receipt_s, delay_s)

    @property
    def has_measurement(self) -> bool:
        return self._readings.latest is not None

    def halt(self, halted: bool) -> None:
        """An e-stop holds the drive: command nothing; when it is released,
        re-acquire from the measurement."""
        if halted and not self._halted:
            self._reference.request_reacquire()
        self._halted = halted

    def brakes(self, engaged: bool) -> None:
        """The drive reports its brakes. While they hold, whatever this
        controller commands does not move the arm: start again from the
        measurement every tick (no integral winds up), so the release finds a
        reference that begins where the arm is. Their release asks for one more
        start: a reading taken while they held, or across the moment they let
        go, shows the brake's work, which the filter's model knows nothing of
        (a one-tick brake took 3 rad/s off the arm, and the filter read it as
        a 10 N·m external torque)."""
        if self._braked and not engaged:
            self._reference.request_reacquire()
        self._braked = engaged

    # --- the tick ---------------------------------------------------------------------

    def update(self, now_s: float) -> ControlOutput:
        """Compute the command for the tick at ``now_s`` seconds."""
        tick = self._advance_clock(now_s)
        self._reference.planner.advance_to(now_s)  # the samples that were sent ahead of their time
        health = self._check_health(now_s)
        if not health.status.commanding:
            return self._no_command(now_s, health.status)
        if self.law_fault is not None:
            return self._stop_after_law_fault(now_s, tick.dt_s, health.status)
        # Late first: its stop runs open loop on the model, readings or not, and a late link
        # delivers readings in gaps; left to the watchdog, each gap began another stop on the
        # model whose commands released the brakes the late stop had left holding.
        if self._latency is not None and self._late(now_s):
            return self._stop_when_late(now_s, tick.dt_s)
        if health.status is Status.WATCHDOG:
            return self._stop_on_model(now_s, tick.dt_s)
        self._sensor_rest_s = None
        if self._reference.reacquire_pending:
            self._restart_from_measurement(now_s)
        position, velocity = self._estimate_at_tick(now_s)
        reference = self._reference_at_tick(now_s, position)
        return self._apply_law(now_s, tick.dt_s, position, velocity, reference)
