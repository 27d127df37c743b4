"""What a FollowJointTrajectory goal hears of the arm while it is in force (ports ``state``, ``reading``, ``brakes``,
``estop``, each with the planner's time at receipt), and from it whether the arm can still be judged, or why the goal
must end.

The brakes are heard all the time, every message kept, so an engagement released before the planner looks is still
seen; an engagement during a goal ends it even if released since, as the arm stood braked meanwhile (a goal that
starts while they hold ends at once). The controller's state is stale once the planner has heard none for
``STALE_PERIODS`` of the controller's period (seen in the stamps of its state), at two checks in a row: a planner
held up checks once before it takes what arrived meanwhile. A controller that publishes no state (the tutorial's) is
judged on the readings the same way. Ages are the planner's own clock at receipt, never another process's stamp."""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from robot_controller.blocks import spec
from robot_controller.blocks.values import Array, JointSample, brake_reasons
from robot_controller.core.controller import state_layout

#: Controller states that end a goal: the loop is stopping or stopped, whatever the reference does.
FAULT_STATES = frozenset(
    ("watchdog", "sensor_lost", "reference_lost", "stopped", "law_fault", "law_stopped", "late", "late_stopped")
)
_STATUS_NAMES = {code: name for name, code in state_layout.STATUS_CODES.items()}
STALE_PERIODS = 5  #: how many of the controller's periods without its state make it stale
PERIOD_SAMPLES = 20  #: the controller's period is the median of this many intervals between its states' stamps
FIRST_HEARD_S = 3.0  #: how long a goal may wait to hear the arm at all (new subscriptions match meanwhile)


@dataclass(frozen=True)
class Estimate:
    """The controller's latest state: its tick (its clock), when the planner heard it (the planner's clock), the
    reference it compared with, its estimate and its status."""

    time_s: float
    received_s: float
    reference: np.ndarray
    measured: np.ndarray
    status: str


class ArmWatch:
    """The planner's ears for a goal."""

    def __init__(self, joint_names: Sequence[str], own_period_s: float, *, world_waits: bool) -> None:
        """:param own_period_s: the planner's step period, s (it checks once per step)
        :param world_waits: the world holds its brakes from its start until the first effort (not a fault)"""
        self.joint_names = list(joint_names)
        self.own_period_s = own_period_s
        self.world_waits = world_waits
        self.estop = False
        self.brakes_now: str | None = None  #: why the brakes hold, while they do (None: released)
        self.forget(0.0)

    def forget(self, now_s: float) -> None:
        """Forget what was heard of the arm (listening from ``now_s``): a goal is never judged on an earlier one's."""
        self.estimate: Estimate | None = None
        self.measured: tuple[float, np.ndarray, np.ndarray] | None = None  #: (received s, positions, velocities)
        self.intervals: deque[float] = deque(maxlen=PERIOD_SAMPLES)
        self.braked: str | None = None  #: why the brakes engaged since the goal began (latched until the next goal)
        self.since_s = now_s  #: listening since
        self.stale_checks = 0

    def new_goal(self) -> None:
        """A goal starts: only the brakes' engagements from now on (and their state now) count against it."""
        self.braked = self.brakes_now

    def take(self, port: str, value, now_s: float) -> None:
        if port == "reading":
            self.joint_states(value, now_s)
        elif port == "state":
            self.controller_state(value, now_s)
        elif port == "brakes":
            self.brakes(value)
        elif port == "estop":
            self.estop = bool(value)

    def joint_states(self, sample: JointSample, now_s: float) -> None:
        names = list(sample.names)
        if len(sample.position) != len(names) or any(name not in names for name in self.joint_names):
            return
        order = [names.index(name) for name in self.joint_names]
        position = np.asarray(sample.position, dtype=float)[order]
        velocity = sample.velocity if len(sample.velocity) == len(names) else np.zeros(len(names))
        self.measured = (now_s, position, np.asarray(velocity, dtype=float)[order])

    def controller_state(self, state: Array, now_s: float) -> None:
        n = len(self.joint_names)
        if not state_layout.fits(len(state.data), n):
            return
        decoded = state_layout.decode(np.asarray(state.data, dtype=float), n)
        time_s = float(decoded["time_s"])
        if self.estimate is not None and time_s > self.estimate.time_s:
            self.intervals.append(time_s - self.estimate.time_s)
        status = _STATUS_NAMES.get(int(decoded["status"]), "ok")
        self.estimate = Estimate(time_s, now_s, decoded["reference"], decoded["measured"], status)

    def brakes(self, brakes: Array) -> None:
        values = np.asarray(brakes.data, dtype=float)
        if values.size != len(self.joint_names):
            return
        if np.any(values > 0.5):
            reasons = brake_reasons(brakes.label) or set()
            if self.world_waits and reasons == {"start"}:
                return  # held for the world's start, released by the controller's first effort (as it reads them)
            self.brakes_now = ", ".join(sorted(reasons)) or "no reason given"
            self.braked = self.braked or self.brakes_now
        else:
            self.brakes_now = None

    def fault(self, now_s: float) -> str | None:
        """Why the goal cannot go on (None: it can): the e-stop, the brakes, the controller's fault or its silence."""
        if self.estop:
            return "e-stop: the arm is braked"
        if self.braked is not None:
            return f"the arm's brakes engaged ({self.braked}): the arm is not following the trajectory"
        estimate = self.estimate
        if estimate is not None and estimate.status in FAULT_STATES:
            return f"the controller reports {estimate.status}: the loop stops"
        return self._silence(now_s)

    def _heard(self) -> tuple[float | None, str]:
        """When the arm was last heard (None: not yet), and on what: the controller's state, else the readings."""
        if self.estimate is not None:
            return self.estimate.received_s, f"the controller's state ({spec.STATE.topic})"
        if self.measured is not None:
            return self.measured[0], f"the arm's readings ({spec.READING.topic})"
        return None, ""

    def _silence(self, now_s: float) -> str | None:
        heard, source = self._heard()
        if heard is None:
            waited = now_s - self.since_s
            return None if waited <= FIRST_HEARD_S else f"nothing heard of the arm in {waited:.2f} s"
        age, limit = now_s - heard, self.stale_after_s()
        self.stale_checks = self.stale_checks + 1 if age > limit else 0
        if self.stale_checks < 2:
            return None
        return f"{source} is stale: none for {age:.3f} s, over {limit:.3f} s ({STALE_PERIODS} control periods)"

    def stale_after_s(self) -> float:
        """How long without the controller's state is too long: a few of its periods, no less than two of the
        planner's own steps (it checks once per step)."""
        own = self.own_period_s
        period = float(np.median(self.intervals)) if self.intervals else own
        return max(STALE_PERIODS * period, 2.0 * own)

    def fresh(self, now_s: float) -> bool:
        """Whether what the arm is judged on was heard within the stale limit."""
        heard = self._heard()[0]
        return heard is not None and now_s - heard <= self.stale_after_s()
