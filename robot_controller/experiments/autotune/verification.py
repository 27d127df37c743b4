"""Whether a tuned design is worth using: the gains in force and the design, each run on the real graph on sim time
with the same seeds (the same sensor noise), the worst joint's sine RMS compared seed by seed. The design is
recommended only if it tracks better by more than twice the standard error of that difference, and every run of it
ends ``ok``: a design within its own uncertainty of what is in force is no advice."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.experiments.step import run_sim_time

#: Standard errors the paired improvement must pass.
SIGNIFICANCE = 2.0


@dataclass(frozen=True)
class Verification:
    seeds: tuple[int, ...]
    before_rad: tuple[float, ...]  #: the worst joint's tracking RMS per seed, gains in force
    after_rad: tuple[float, ...]  #: the same with the design
    after_ok: bool  #: every run of the design ended ok
    duration_s: float

    @property
    def unchanged(self) -> bool:
        """The design is the configuration in force: nothing was run."""
        return not self.before_rad

    @property
    def improvement_rad(self) -> float:
        return float(np.mean(np.subtract(self.before_rad, self.after_rad))) if self.before_rad else 0.0

    @property
    def stderr_rad(self) -> float:
        """Of the mean paired improvement (0 for one seed: no spread to judge it by)."""
        differences = np.subtract(self.before_rad, self.after_rad)
        return float(np.std(differences, ddof=1) / np.sqrt(len(differences))) if len(differences) > 1 else 0.0

    @property
    def recommended(self) -> bool:
        if self.unchanged or not self.after_ok:
            return False
        improvement = self.improvement_rad
        return bool(improvement > SIGNIFICANCE * self.stderr_rad and improvement > 0)

    def verdict(self) -> str:
        """One line: the figures before and after and whether to use the design."""
        if self.unchanged:
            return "the design is the configuration in force: nothing better found, nothing written to use"
        before, after = np.mean(self.before_rad) * 1e3, np.mean(self.after_rad) * 1e3
        figures = (
            f"the real graph's sine RMS (worst joint, {len(self.seeds)} seeds of {self.duration_s:g} s) goes from "
            f"{before:.3g} to {after:.3g} mrad ({self.improvement_rad * 1e3:+.2g} ± {self.stderr_rad * 1e3:.2g} "
            "mrad better)"
        )
        if self.recommended:
            return f"{figures}: recommended"
        why = "a run of it did not end ok" if not self.after_ok else "not better than what is in force past its spread"
        return f"{figures}: not recommended ({why}); nothing better found, nothing written to use"

    def as_values(self) -> dict[str, Any]:
        if self.unchanged:
            return {"verified_seeds": 0, "unchanged": 1, "recommended": 0}
        values: dict[str, Any] = {
            "verified_seeds": len(self.seeds),
            "verified_duration_s": self.duration_s,
            "real_rms_before_rad": float(np.mean(self.before_rad)),
            "real_rms_after_rad": float(np.mean(self.after_rad)),
            "real_improvement_rad": self.improvement_rad,
            "real_improvement_stderr_rad": self.stderr_rad,
            "recommended": int(self.recommended),
        }
        for seed, before, after in zip(self.seeds, self.before_rad, self.after_rad, strict=True):
            values[f"real_rms_before_seed{seed}_rad"], values[f"real_rms_after_seed{seed}_rad"] = before, after
        return values


def verify(
    before: cfg.Params,
    after: cfg.Params,
    *,
    seeds: tuple[int, ...],
    duration_s: float,
    out: Path,
    progress: Callable[[str], None],
) -> Verification:
    """Run ``before`` and ``after`` on sim time with each of ``seeds`` (in ``out/real_{before,after}_seed{N}``); no
    run where they are the same configuration."""
    if before == after:
        return Verification(tuple(seeds), (), (), True, duration_s)
    figures: dict[str, list[float]] = {"before": [], "after": []}
    after_ok = True
    for seed in seeds:
        for name, params in (("before", before), ("after", after)):
            progress(f"real graph, {name}, seed {seed}: {duration_s:g} s sine on sim time")
            seeded = cfg.merge(params, {"sensor_node": {"seed": seed}})
            scored, _ = run_sim_time(seeded, out / f"real_{name}_seed{seed}", duration_s)
            figures[name].append(float(scored["tracking_rms_rad"]))
            if name == "after":
                after_ok = after_ok and scored.get("verdict", "ok") == "ok"
    return Verification(tuple(seeds), tuple(figures["before"]), tuple(figures["after"]), after_ok, duration_s)
