"""The controller block's own timing: the command path's delay (the drive's receipts paired with the ticks that issued
each command), the line while the loop is later than its gains survive, and the loop's regularity over the last
diagnostics period (port ``diagnostics``: ticks, jitter, missed cycles, the readings' age at their tick)."""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from robot_controller.blocks.block import Log
from robot_controller.core import metrics
from robot_controller.core.controller import JointController

# While the loop is late, its one line comes at most this often (s).
LATE_LINE_PERIOD_S = 2.0
# Commands remembered with their tick time, to pair with the drive's receipts (a second's worth and more).
ISSUED_KEPT = 400
#: The name the diagnostics report goes by (the live view and ``ros2 topic echo`` show it).
DIAGNOSTICS_NAME = "pid_controller: control loop"


@dataclass(frozen=True)
class Diagnostics:
    """The value of port ``diagnostics``: the loop's health over the last period."""

    name: str
    level: str  #: "ok" or "warn"
    message: str
    values: dict[str, float] = field(default_factory=dict)
    stamp_s: float = 0.0  #: s, when it was made


class LoopTiming:
    """How late and how regular the controller's loop is; where the world waits for each command, a tick takes no time
    on its clock and the drive's receipts say nothing."""

    def __init__(self, controller: JointController, log: Log, world_waits: bool) -> None:
        self.controller = controller
        self.log = log
        self.world_waits = world_waits
        self.issued: deque[tuple[float, tuple[float, ...]]] = deque(maxlen=ISSUED_KEPT)  # (tick s, command)
        self.window_ticks: list[float] = []
        self.window_latency: list[float] = []
        self.next_late_line = -np.inf  # s

    def note_tick(self, now_s: float, command: tuple[float, ...] | None) -> None:
        self.window_ticks.append(now_s)
        if not self.world_waits:
            if command is not None:
                self.issued.append((now_s, command))
            self.window_latency.append(now_s - self.controller.measurement_stamp_s)

    def take_receipts(self, data: np.ndarray, joint_count: int) -> None:
        """The drive's receipts, rows ``[receipt_time_s, command…]``, each paired with the latest tick that issued
        the same command before it: the command path's delay."""
        row = 1 + joint_count
        data = np.asarray(data, dtype=float).tolist()
        if not data or len(data) % row:
            return
        ticks: dict[tuple[float, ...], list[float]] = {}
        for tick_s, command in self.issued:
            ticks.setdefault(command, []).append(tick_s)
        for start in range(0, len(data), row):
            receipt_s, command = data[start], tuple(data[start + 1 : start + row])
            earlier = [t for t in ticks.get(command, ()) if t <= receipt_s]
            if earlier:
                self.controller.command_delay(receipt_s, receipt_s - earlier[-1])

    def report_late(self, now_s: float) -> None:
        """One line (at most every LATE_LINE_PERIOD_S) while the loop is later than its gains survive."""
        if now_s < self.next_late_line:
            return
        self.next_late_line = now_s + LATE_LINE_PERIOD_S
        late = self.controller.latency
        margin = self.controller.delay_margin_periods()
        self.log.warning(
            f"readings/commands {late.delay_s * 1e3:.0f} ms late beyond what the stamps account for; the gains "
            f"survive {late.tolerated_s * 1e3:.0f} ms (delay margin {margin} periods): controlled stop, holding "
            f"until it is back within {late.tolerated_s * 0.5e3:.0f} ms for 1 s (category 2)",
        )

    def diagnostics(self, now_s: float) -> Diagnostics:
        """The last period's figures; the next period starts from its last tick."""
        ticks, latency = self.window_ticks, self.window_latency
        self.window_ticks, self.window_latency = ticks[-1:], []
        values: dict[str, float] = {"ticks": float(max(len(ticks) - 1, 0))}
        if len(ticks) >= 2:
            values.update(metrics.rate_metrics(np.asarray(ticks), self.controller.config.control_period_s))
        values.update(metrics.latency_metrics(np.asarray(latency)))
        if len(ticks) < 2:
            level, message = "warn", "not commanding"
        elif values.get("missed_cycles", 0) > 0:
            level, message = "warn", f"{int(values['missed_cycles'])} missed cycle(s)"
        else:
            level, message = "ok", "running"
        return Diagnostics(DIAGNOSTICS_NAME, level, message, values, now_s)
