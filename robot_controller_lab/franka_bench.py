"""The Panda through libfranka on the stand-in Franka robot (franka-sim, our Panda inside, its communication
constraints and motion limits enforced), as a user runs it: ``robot-controller run --robot panda --hardware
franka://HOST``, the graph around the drive. How long a tick takes against the robot's 1 ms, how many periods the robot
counts missed, the commands it took in time, the tracking and the verdict, from the run's own ``metrics.json``.
franka-sim's venv is made by ``make franka-sim``; without it, or without pylibfranka, the figures are not measured and
say why."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path
from typing import Any

FIGURES = (
    "franka_ok",
    "franka_tracking_rms_rad",
    "franka_tick_p50_ms",
    "franka_tick_p99_ms",
    "franka_tick_max_ms",
    "franka_missed",
    "franka_success_rate",
    "franka_success_rate_min",
)
#: each figure, by the run's metrics.json key it is
FROM_METRICS = {
    "franka_tracking_rms_rad": "tracking_rms_rad",
    "franka_tick_p50_ms": "tick_compute_p50_ms",
    "franka_tick_p99_ms": "tick_compute_p99_ms",
    "franka_tick_max_ms": "tick_compute_max_ms",
    "franka_missed": "robot_missed_cycles",
    "franka_success_rate": "command_success_rate",
    "franka_success_rate_min": "command_success_rate_min",
}
#: s a run may take beyond its duration (the graph's start, the stand-in's, the scoring)
SLACK_S = 120.0


def franka_run(out: Path, duration_s: float) -> dict[str, Any]:
    """``duration_s`` s of ``run --hardware`` on a fresh stand-in: :data:`FIGURES`, or ``franka_failure`` saying what
    kept them from being measured (or how the run failed)."""
    try:
        import pylibfranka  # noqa: F401 - only whether it is there
    except ImportError:
        return {"franka_failure": "pylibfranka is not installed (the franka extra)"}
    from robot_controller.hardware import franka_server

    if not (franka_server.default_venv() / ".installed").is_file():
        return {"franka_failure": "franka-sim's venv is missing: run `make franka-sim`"}
    out.mkdir(parents=True, exist_ok=True)
    flags = ("--enforce-comm-constraints", "--enforce-motion-limits")
    run_dir = out / "run"
    try:
        with franka_server.FrankaServer(franka_server.write_panda_mjcf(out), flags=flags) as server:
            command = [sys.executable, "-m", "robot_controller.cli", "run", "--robot", "panda"]
            command += ["--hardware", f"franka://{server.host}", "--duration", repr(duration_s), "--out", str(run_dir)]
            done = subprocess.run(command, capture_output=True, text=True, timeout=duration_s + SLACK_S)
    except franka_server.FrankaServerError as exc:
        return {"franka_failure": str(exc)}
    except subprocess.TimeoutExpired:
        return {"franka_failure": f"the run did not end within {duration_s + SLACK_S:g} s"}
    (out / "run.log").write_text(done.stdout + done.stderr)
    try:
        metrics = json.loads((run_dir / "metrics.json").read_text())
    except (OSError, ValueError):
        return {"franka_failure": f"the run left no metrics (exit {done.returncode}); see {out / 'run.log'}"}
    figures: dict[str, Any] = {key: metrics.get(name) for key, name in FROM_METRICS.items()}
    figures["franka_ok"] = 1.0 if metrics.get("verdict") == "ok" else 0.0
    if metrics.get("verdict") != "ok":
        figures["franka_failure"] = (metrics.get("run_failure") or "; ".join(metrics.get("verdict_reasons") or []))[
            :300
        ]
    return figures
