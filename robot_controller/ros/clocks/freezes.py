"""Wall-clock gaps a clock of the world woke up late by (the host's, or its own process's, freezes), and how they
are said at the end and left for ``metrics.json``."""

from __future__ import annotations

import json
from pathlib import Path

from robot_controller.blocks.block import Log
from robot_controller.ros.process import WORLD_CLOCK_FILE

#: How the world's figures read in its closing line.
SAID = {
    "late_efforts": "late efforts (the loop's own)",
    "late_efforts_host": "late efforts the host made late",
    "stale_efforts": "stale efforts dropped",
}


class FreezeLog:
    """Wall-clock gaps the world paused for: how many, the longest and the total, ms."""

    def __init__(self) -> None:
        self.count = 0
        self.max_ms = 0.0
        self.total_ms = 0.0

    def note(self, gap_ns: int) -> None:
        self.count += 1
        self.max_ms = max(self.max_ms, gap_ns * 1e-6)
        self.total_ms += gap_ns * 1e-6

    def figures(self) -> dict[str, float]:
        return {
            "host_freezes": self.count,
            "host_freeze_ms_max": round(self.max_ms, 3),
            "host_freeze_ms_total": round(self.total_ms, 3),
        }

    def say_and_leave(self, log: Log, counts_dir: str, meaning: str, **more: int) -> None:
        """Say the freezes (and ``more`` figures) in one line, and leave them in ``counts_dir`` for metrics.json."""
        figures = {**self.figures(), **more}
        if self.count or any(more.values()):
            said = ", ".join(f"{value} {SAID.get(name, name.replace('_', ' '))}" for name, value in more.items())
            log.info(
                f"the host froze this simulator {self.count} time(s) (longest {self.max_ms:.0f} ms, "
                f"{self.total_ms:.0f} ms in all): {meaning}" + (f"; {said}" if said else "")
            )
        if counts_dir:
            (Path(counts_dir) / WORLD_CLOCK_FILE).write_text(json.dumps(figures))
