"""The check on the real graph: one seeded lockstep sine run with the configured
gains and one with the tuned ones (five processes, ``step.run_and_score``), to
show what the batch harness does not model."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from robot_controller import parameters as cfg


def real_graph(
    params: cfg.Params,
    tuned_params: cfg.Params,
    out: Path,
    *,
    duration_s: float,
    seed: int,
    progress: Callable[[str], None],
) -> dict[str, Any]:
    """Run before and after (in ``out/real_before``, ``out/real_after``): their tracking RMS, worst error and
    peak torque, flat, and the runs' length."""
    from robot_controller.experiments.exercises.common import run_lockstep

    values: dict[str, Any] = {}
    sine_overrides = {"sensor_node": {"seed": seed}}
    for name, run_params in (("before", params), ("after", tuned_params)):
        progress(f"real graph, {name}: {duration_s:g} s sine in lockstep")
        figures, _ = run_lockstep(cfg.merge(run_params, sine_overrides), out / f"real_{name}", duration_s)
        values[f"real_rms_{name}_rad"] = figures["tracking_rms_rad"]
        values[f"real_max_{name}_rad"] = figures["tracking_max_rad"]
        values[f"real_peak_torque_{name}_nm"] = figures["peak_torque_nm"]
    values["real_duration_s"] = duration_s
    return values
