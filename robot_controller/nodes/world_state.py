"""The simulated arm's joint positions in a memory-mapped file (written on every pacing
tick, no system call), so that a respawned simulator finds the arm where it was."""

from __future__ import annotations

from pathlib import Path

import numpy as np

# Set by the launcher (with --respawn) to the file's path.
WORLD_STATE_ENV = "ROBOT_CONTROLLER_WORLD_STATE"

# [valid flag, position per joint]
_VALID = 1.0


class WorldState:
    def __init__(self, array: np.memmap, resumed: np.ndarray | None) -> None:
        self._array = array
        self.resumed = resumed  #: the positions found at start (a respawn), or None

    @classmethod
    def open(cls, path: str, joint_count: int) -> WorldState | None:
        """The state file at ``path`` (None: no path); one left by an earlier simulator gives ``resumed``."""
        if not path:
            return None
        file = Path(path)
        size = (1 + joint_count) * 8
        resumed = None
        if file.is_file() and file.stat().st_size == size:
            previous = np.fromfile(file, dtype=np.float64)
            if previous[0] == _VALID and np.all(np.isfinite(previous[1:])):
                resumed = previous[1:].copy()
        else:
            file.write_bytes(b"\0" * size)
        return cls(np.memmap(file, dtype=np.float64, mode="r+", shape=(1 + joint_count,)), resumed)

    def save(self, position: np.ndarray) -> None:
        self._array[1:] = position
        self._array[0] = _VALID
