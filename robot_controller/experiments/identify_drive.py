"""``identify``'s drive: the lag between the controller's commands and the torque the drive applied over a run
(:func:`~robot_controller.core.model.drive_lag.fit_lag`), added to what ``identify`` wrote as the controller's
``model_drive_lag_s``. A lag the controller is not told of costs it the phase of two periods at 20 ms and 100 Hz (a
light wrist's 1 mrad becomes 5); told, it inverts it (docs/controller.md, "The drive's lag")."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.core.model.drive_lag import fit_lag
from robot_controller.scoring import report

#: a lag under this many seconds is none: the drive follows within the period (the controller inverts nothing)
NO_LAG_S = 1e-4


def graph_commands_and_efforts(recording: Any, period_s: float) -> tuple[np.ndarray, np.ndarray]:
    """A graph's run as (command, torque applied) per period: the bag's true effort at each tick is the torque the
    drive applied after the command of the tick before (a row each, a column per joint)."""
    state = recording.state
    ticks_s, commands = np.asarray(state["time_s"]), np.asarray(state["command"])
    times_s, efforts = recording.true_time_s, recording.true_effort
    index = np.searchsorted(ticks_s, times_s - period_s - 1e-6)  # the tick a period before each effort's
    found = index < len(ticks_s)
    found[found] &= np.abs(ticks_s[index[found]] - (times_s[found] - period_s)) < 0.25 * period_s
    return commands[index[found]], efforts[found]


def add_drive_lag(
    out: Path, command: np.ndarray, applied: np.ndarray, period_s: float, progress: Callable[[str], None]
) -> dict[str, Any]:
    """Fit the drive's lag to a run's commands and torques applied (a row per control period) and add it to
    ``out``'s ``identified.yaml``, ``identification.json`` and ``identification.md``; returns what it adds to the
    json."""
    lag_s, stderr_s = fit_lag(command, applied, period_s)
    if lag_s < NO_LAG_S:
        lag_s = 0.0
    identified = cfg.read_params_file(out / "identified.yaml")
    cfg.write_params_file(
        cfg.merge(identified, {"pid_controller": {"model_drive_lag_s": float(f"{lag_s:.6g}")}}), out / "identified.yaml"
    )
    values = {"drive_lag_s": lag_s, "drive_lag_stderr_s": stderr_s}
    json_path = out / "identification.json"
    report.write_metrics(json_path, {**json.loads(json_path.read_text()), **values})
    said = (
        "none (the drive applies each command within its period)"
        if lag_s == 0
        else (f"{lag_s * 1e3:.3g} ms ± {stderr_s * 1e3:.2g} (a first-order lag; the controller inverts it)")
    )
    with (out / "identification.md").open("a") as markdown:
        markdown.write(f"\nThe drive's lag, from the commands and the torques it applied: {said}.\n")
    progress(f"identify: the drive's lag {said}")
    return values
