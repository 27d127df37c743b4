"""The controller (the graph's ``pid_controller``): it holds the ``JointController`` (every decision about torque)
and says what its tick did. Its host's clock decides when it ticks (``step``); what arrives between ticks is taken
with ``take``. A gain change, checked (its law designed) on any thread, takes effect at the start of the next tick."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.blocks import spec
from robot_controller.blocks.block import Log
from robot_controller.blocks.controller_reports import LAW_STOPPED_EXIT_CODE, LogSchedule, Reports, StartWaits, log_line
from robot_controller.blocks.controller_timing import LoopTiming
from robot_controller.blocks.values import (
    Array,
    JointSample,
    at_tick,
    brakes_label,
    check_joint_state,
    check_trajectory,
)
from robot_controller.core.controller import (
    ControllerConfig,
    JointController,
    Status,
    check_delay_margin,
    delay_margin_periods,
    law_config,
)
from robot_controller.core.controller.supervision import PositionNoise
from robot_controller.core.errors import ConfigError
from robot_controller.core.laws import law_parameters, registry
from robot_controller.core.laws.containment import BLOCKED_S
from robot_controller.parameters.builders import arm_model, model_overridden

# Readings naming other joints for this long (s of the caller's wall clock), none usable yet: a configuration mismatch.
CONFIG_MISMATCH_S = 2.0
# The parameters whose change makes the law in force say itself again.
GAIN_KEYS = frozenset({"controller_type", "lqr_q", "lqr_r", "kp", "ki", "kd", "control_rate_hz"})
# After a failed law's stop on the wall clock, state goes on this long (s; the brakes engaging are recorded) before
# the block asks to end. Where the world waits it ends at once: without commands the world's time stops.
LAW_STOPPED_LINGER_S = 0.5

MarginOf = Callable[[ControllerConfig], "int | None"]  # a configuration → its delay margin, control periods


def designed_margin(config: ControllerConfig, dynamics: Any, joint_count: int) -> int | None:
    """``config``'s built-in law designed, its delay margin in control periods (the worst joint's; None for a law of
    one's own, whose feedback is not known here); ``ConfigError`` for a design that does not stabilise or leaves less
    than ``min_delay_margin_periods``. One design and one margin: a margin takes tens of ms per joint."""
    margin = delay_margin_periods(law_config(config, dynamics, joint_count), dynamics, joint_count, config)
    if margin is not None and margin < config.min_delay_margin_periods:
        check_delay_margin(config, dynamics, joint_count)  # refuses, naming the joint (only now computed per joint)
    return None if config.plugin_law else margin


@dataclass
class GainChange:
    """An accepted change: the whole configuration it makes, the parameters it changed and the margin found for it."""

    config: ControllerConfig
    params: dict[str, Any]
    changed: set[str]
    margin: int | None


def position_noise(sample: JointSample) -> PositionNoise | None:
    """What a reading says of its positions' errors, if anything (a camera's)."""
    if sample.position_std is None:
        return None
    return PositionNoise(sample.position_std, sample.position_correlation)


def ordered(values: np.ndarray, names: list[str], joint_names: list[str]) -> np.ndarray | None:
    """Per-joint ``values`` given in the order ``names`` (none: the arm's) in the arm's order, or None."""
    values = np.asarray(values, dtype=float)
    if values.size != len(joint_names):
        return None
    if not names or list(names) == joint_names:
        return values
    index = {name: k for k, name in enumerate(names)}
    return values[[index[name] for name in joint_names]]


class UnseenJoints:
    """Which joints the readings say nothing of (a camera's: no marker it sees constrains them): each runs on the
    arm's model while so, said once when it starts and once when it ends."""

    def __init__(self, joint_names: list[str], log: Log) -> None:
        self.joint_names, self.log = joint_names, log
        self.unseen: dict[str, float] = {}  #: joint → the stamp since which the readings say nothing of it
        self.episodes: list[tuple[str, float, float]] = []  #: (joint, from s, to s) of each episode ended

    def take(self, stamp_s: float, position_std: np.ndarray | None) -> None:
        if position_std is None:
            if self.unseen:
                position_std = np.zeros(len(self.joint_names))
            else:
                return
        for name, sigma in zip(self.joint_names, position_std.tolist(), strict=True):
            blind = not np.isfinite(sigma)
            if blind and name not in self.unseen:
                self.unseen[name] = stamp_s
                self.log.warning(f"{name}: no marker in the camera's view constrains it: it runs on the arm's model")
            elif not blind and name in self.unseen:
                since_s = self.unseen.pop(name)
                self.episodes.append((name, since_s, stamp_s))
                self.log.info(f"{name}: seen again after {stamp_s - since_s:.2f} s on the arm's model")


def _same(params: Mapping[str, Any], other: Mapping[str, Any]) -> bool:
    try:
        return dict(params) == dict(other)
    except ValueError:  # an array among them: compared as a whole, it has no one truth value
        return False


class Controller:
    inputs = ("reading", "camera_reading", "reference", "estop", "brakes", "command_receipts")
    outputs = ("command", "state", "diagnostics")

    def __init__(
        self,
        params: Mapping[str, Any],
        log: Log,
        *,
        world_waits: bool,
        margin_of: MarginOf | None = None,
        run_wait: Callable[[], float] | None = None,
    ) -> None:
        """:param world_waits: each command acts from its tick and the world waits for it (sim time, the paced
        world): no latency guard, the start's brakes are not heard (their release is a race) and a failed law's stop
        ends the block at once.
        :param margin_of: :func:`designed_margin`, or a host's stand-in running it in a process of its own
        (``nodes.live_gains``).
        :param run_wait: on the wall clock, how long (s) the host has kept this thread from running so far (run-queue
        wait, steal), which a law's budget does not count."""
        self.log = log
        self.world_waits = world_waits
        self.dynamics = arm_model(params)
        self.joint_names = list(self.dynamics.joint_names)
        self.joint_count = len(self.joint_names)
        self._margin_of = margin_of or (lambda config: designed_margin(config, self.dynamics, self.joint_count))
        if model_overridden(params):
            self.log.info(self.dynamics.describe())
        self.controller: JointController | None = None
        # Every built-in law found now: the first lookup reads every installed package's entry points (6 ms), which a
        # switch of law at a tick would otherwise pay on the loop's thread.
        for law in registry.BUILTIN_LAWS:
            registry.resolve(law)
        self.check_params(params)
        # A law of one's own is held to its law_budget_s: where the world waits, on its thread's CPU time (a call
        # blocked for BLOCKED_S of wall time is abandoned); on the wall clock, on wall time less what the host took
        # from its thread, and the loop's delay is watched against the gains' delay margin.
        self.controller = JointController(
            self.checked.config,
            self.joint_count,
            self.dynamics,
            law_clock=time.thread_time if world_waits else time.perf_counter,
            latency_guard=not world_waits,
            law_run_wait=None if world_waits else run_wait,
        )
        if world_waits and self.controller.plugin is not None:
            self.controller.plugin.abandon_s = BLOCKED_S
        self.params = dict(params)
        # The newest accepted change, offered by the checking thread, taken by the loop's at a tick; the lock is held
        # for an assignment or two: the loop never waits on a design.
        self._lock = threading.Lock()
        self._pending: GainChange | None = None
        self.reports = Reports(self.log, self.controller, world_waits)
        self.timing = LoopTiming(self.controller, self.log, world_waits)
        self.waits = StartWaits(self.log)
        self.state_blocks = self.reports.state_blocks  #: the state row's (label, size) blocks
        self.last_tick_s = -np.inf
        self.first_tick_s: float | None = None
        self.status: Status | None = None  #: the last tick's
        self.reference_samples = 0  # usable reference samples so far (two teach the controller the planner's period)
        self.law_stopped_since: float | None = None
        self.exit_code: int | None = None  #: set once the block has ended (a failed law's stop is over)
        self.mismatch_since: float | None = None
        self.log_schedule = LogSchedule(params["log_period_s"])
        self.unseen = UnseenJoints(self.joint_names, self.log)
        self.reports.log_gains(self.checked.margin, params["control_rate_hz"])

    def check_params(self, params: Mapping[str, Any]) -> None:
        """The law designed before the change is accepted (an LQR that does not stabilise is refused, not found when
        applying it); ``checked`` is what ``set_params`` hands over. The values running are not designed again."""
        if self.controller is not None and _same(params, self.params):
            self.checked = GainChange(self.controller.config, dict(params), set(), self.checked.margin)
            return
        config = cfg.controller_config(params, self.joint_count)
        running = self.controller
        changed = running is not None and config.controller_type != running.config.controller_type
        if changed and (config.plugin_law or running.config.plugin_law):
            raise ConfigError(
                "controller_type: a law of one's own is chosen when the controller starts; restart it to change"
            )
        if config.plugin_law:  # per-joint lengths and the like, as the law will be given them
            law_parameters.values(registry.resolve(config.controller_type), config.law_parameters, self.joint_count)
        self.checked = GainChange(config, dict(params), set(), self._margin_of(config))

    def set_params(self, params: Mapping[str, Any], changed: set[str]) -> None:
        """Take checked values (on any thread) for the loop's next tick; a change not yet taken is replaced, its
        configuration being whole, and what either changed is said."""
        change = GainChange(self.checked.config, dict(params), set(changed), self.checked.margin)
        with self._lock:
            if self._pending is not None:
                change.changed |= self._pending.changed
            self._pending = change

    def take_gain_change(self) -> None:
        """At the start of a tick: the newest accepted change, if any, takes over (bumpless: the PID keeps its I term
        in N·m); should the controller refuse it even so, the law in force stays, said."""
        if self._pending is None:  # nearly every tick: no lock taken
            return
        with self._lock:
            change, self._pending = self._pending, None
        try:
            self.controller.set_config(change.config)
        except ConfigError as exc:
            self.log.warning(f"the law in force stays: the change to {sorted(change.changed)} was refused ({exc})")
            return
        self.params = change.params
        if change.changed & GAIN_KEYS or any(law_parameters.is_law_key(name) for name in change.changed):
            self.reports.log_gains(change.margin, change.params["control_rate_hz"])

    def start(self) -> dict[str, Any]:
        return {}

    def wake_period_s(self) -> float | None:
        return None  # its host's clock steps it

    def checked_reading(self, sample: JointSample) -> JointSample | None:
        """``sample`` in the arm's joint order, or None (said, rate-limited) if it cannot be used."""
        checked = check_joint_state(sample.names, sample.position, sample.velocity, self.joint_names)
        if isinstance(checked, str):
            self.log.warn(spec.READING.topic, f"{spec.READING.topic} dropped: {checked}")
            return None
        position_std, correlation = sample.position_std, sample.position_correlation
        if position_std is not None:
            position_std = ordered(position_std, sample.names, self.joint_names)
            if position_std is None:
                self.log.warn(spec.READING.topic, f"{spec.READING.topic} dropped: one position σ per joint expected")
                return None
            if correlation is not None:
                rows = ordered(np.arange(len(self.joint_names)), sample.names, self.joint_names).astype(int)
                correlation = correlation[np.ix_(rows, rows)] if correlation.shape == (rows.size,) * 2 else None
        return JointSample(sample.stamp_s, self.joint_names, *checked, None, position_std, correlation)

    def check_names(self, names: list[str], wall_s: float) -> None:
        """Readings naming other joints than this arm's, none usable since start, for ``CONFIG_MISMATCH_S`` of the
        caller's wall clock (``wall_s``): the graph is configured for different arms; ``ConfigError`` naming both."""
        if self.controller.has_measurement or not names or sorted(names) == sorted(self.joint_names):
            self.mismatch_since = None
            return
        self.mismatch_since = self.mismatch_since or wall_s
        if wall_s - self.mismatch_since > CONFIG_MISMATCH_S:
            raise ConfigError(
                f"joint names disagree: {spec.READING.topic} (the simulator's URDF) has {names}, "
                f"pid_controller's URDF ({self.params['urdf_path'] or 'the reference arm'}) has {self.joint_names}"
            )

    def take(self, t_s: float, inputs: Mapping[str, Any]) -> bool:
        """Take what arrived at ``t_s`` between ticks; False if a reading among it was refused (said)."""
        accepted = True
        for port, value in inputs.items():
            if port == "reading":
                accepted = self._take_reading(t_s, value)
            elif port == "camera_reading":
                self._take_camera_reading(t_s, value)
            elif port == "reference":
                self._take_reference(t_s, value)
            elif port == "estop":
                self.controller.halt(bool(value))
            elif port == "brakes":
                self._take_brakes(value)
            elif port == "command_receipts":
                self.timing.take_receipts(value.data, self.joint_count)
        return accepted

    def _take_reading(self, t_s: float, sample: JointSample) -> bool:
        checked = self.checked_reading(sample)
        if checked is None:
            return False
        refused = self.controller.set_measurement(
            checked.stamp_s, t_s, checked.position, checked.velocity, position_noise(checked)
        )
        if refused:
            self.log.warn("joint_states_age", f"{spec.READING.topic} dropped: {refused}")
            return False
        self.unseen.take(checked.stamp_s, checked.position_std)
        return True

    def _take_camera_reading(self, t_s: float, sample: JointSample) -> None:
        """A camera's reading beside the encoder's (``--sensing both``): its positions, each with its σ."""
        checked = self.checked_reading(sample)
        if checked is None:
            return
        if checked.position_std is None:
            self.log.warn("camera_reading", f"{spec.CAMERA_READING.topic} dropped: it says no position σ")
            return
        refused = self.controller.set_second_measurement(
            checked.stamp_s, t_s, checked.position, position_noise(checked)
        )
        if refused:
            self.log.warn("camera_reading_age", f"{spec.CAMERA_READING.topic} dropped: {refused}")

    def _take_reference(self, t_s: float, value: Array) -> None:
        checked = check_trajectory(value.data, self.joint_count)
        if isinstance(checked, str):
            self.log.warn(spec.REFERENCE.topic, f"{spec.REFERENCE.topic} dropped: {checked}")
            return
        self.reference_samples += 1
        self.controller.set_reference(t_s, *checked)

    def _take_brakes(self, value: Array) -> None:
        # While the brakes hold, the reference starts again from the measurement. Where the world waits, not for the
        # start's: the tick their release arrives at is a race, and a run without faults is the same to the bit.
        values = np.asarray(value.data, dtype=float)
        if values.size != self.joint_count or not np.all(np.isfinite(values)):
            return
        engaged = bool(np.any(values > 0.5))
        if self.world_waits and engaged and value.label == brakes_label({"start"}):
            return
        self.controller.brakes(engaged)

    def step(self, t_s: float, inputs: Mapping[str, Any]) -> dict[str, Any]:
        """Take ``inputs`` at ``t_s``, then tick: the torque (``command``, labelled with its tick) if this tick
        commands one, and the tick's terms (``state``); nothing before the first valid reading."""
        if inputs:
            self.take(t_s, inputs)
        self.take_gain_change()
        out = self.controller.update(t_s)
        self.last_tick_s = t_s
        if self.first_tick_s is None:
            self.first_tick_s = t_s
        self.status = out.status
        if out.status is Status.NO_MEASUREMENT:
            self.waits.waiting(
                "readings", f"the first valid {spec.READING.topic} reading (sensor_node's): not commanding", t_s
            )
            return {}
        reports = self.reports
        if out.status is not reports.last_status:
            reports.status_changed(out.status, self.first_tick_s)
        if out.status is Status.LATE:
            self.timing.report_late(t_s)
        outputs: dict[str, Any] = {}
        command = None
        if out.status.commanding:
            outputs["command"] = at_tick(out.command, t_s)
            command = tuple(out.command.tolist())
        self.timing.note_tick(t_s, command)
        reports.say_saturation(out)
        reports.say_adaptation(t_s)
        outputs["state"] = Array(np.asarray(reports.state_row(out)))
        if self.log_schedule.due(t_s, self.params["log_period_s"]):
            self.log.info(log_line(out.reference, out.measured, out.error, out.command))
        if out.status is Status.LAW_STOPPED:
            self._end_after_law_stop(t_s)
        return outputs

    def _end_after_law_stop(self, t_s: float) -> None:
        """The failed law's stop is over: the block ends (``exit_code``)."""
        if self.law_stopped_since is None:
            self.law_stopped_since = t_s
        if self.world_waits or t_s - self.law_stopped_since >= LAW_STOPPED_LINGER_S:
            self.exit_code = LAW_STOPPED_EXIT_CODE
