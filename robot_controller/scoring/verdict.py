"""A run's verdict: ``ok`` only if it tracked within its band from its first tick over all of its duration, no brake
held the arm for a fault, and no stop came that nobody asked for. An e-stop is asked for: said as the user's, never
as the loop's.

It reads ``metrics.json``'s figures only, so ``score`` judges a saved run the same way."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from robot_controller.core.metrics import WARMUP_S
from robot_controller.scoring.summary import FAULT_TICKS, finite

#: A recording may end this much before the run's duration (s, or this share of it if more): the last tick's period,
#: or the tail a stopping recorder loses. Shorter, the rest of the run was never seen, so it cannot be called ok.
RECORDING_SLACK_S, RECORDING_SLACK_SHARE = 0.25, 0.05

#: Controller states that are a stop nobody asked for (``{name}_ticks``); ``stopped`` is the e-stop's, asked for.
UNASKED_STOPS = tuple(name for name in FAULT_TICKS if name != "stopped")


@dataclass(frozen=True)
class Verdict:
    reasons: tuple[str, ...]  #: what the run missed, one clause each; empty: ``ok``

    @property
    def ok(self) -> bool:
        return not self.reasons

    @property
    def line(self) -> str:
        """``ok``, or ``FAILED: <what it missed>``."""
        return "ok" if self.ok else "FAILED: " + "; ".join(self.reasons)

    def as_metrics(self) -> dict[str, Any]:
        return {"verdict": "ok" if self.ok else "failed", "verdict_reasons": list(self.reasons)}


def judge(values: dict[str, Any], *, band_rad: float, failure: str | None = None) -> Verdict:
    """The verdict of a run from ``metrics.json``'s keys.

    :param band_rad: rad (m on a slide), the largest |reference in force − true position| allowed on every joint, the
        start included (a push someone asked for, and ``PUSH_SETTLE_S`` after it, left out)
    :param failure: why the run itself failed (a node died, the law failed), said first
    """
    if failure:  # the stops and the brakes that followed are its own: said once, as the run's failure
        return Verdict((failure,))
    reasons = []
    names = list(values.get("joint_names") or [])
    units = list(values.get("joint_units") or ["rad"] * len(names))
    settled = values.get("unpushed_max_per_joint") or values.get("tracking_max_per_joint")
    start = values.get("start_tracking_max_per_joint")
    if not _all_finite(start) and (not values.get("scored_samples") or not _all_finite(settled)):
        reasons.append("nothing to judge its tracking by (no sample scored)")
    elif values.get("scored_samples") and _all_finite(settled):  # (a run shorter than its start: the start alone)
        pushed = " (pushes left out)" if values.get("unpushed_max_per_joint") is not None else ""
        reasons += [r + pushed for r in _beyond(settled, band_rad, names, units, "tracking")]
    if _all_finite(start):
        reasons += _beyond(start, band_rad, names, units, f"in its first {WARMUP_S:g} s")
    recorded_s, duration_s = values.get("recorded_duration_s"), values.get("duration_s")
    if (
        recorded_s is not None
        and duration_s
        and duration_s - recorded_s > max(RECORDING_SLACK_S, RECORDING_SLACK_SHARE * duration_s)
    ):
        reasons.append(f"its recording covers {recorded_s:.2f} s of its {duration_s:g} s: the rest is not judged")
    faults = values.get("brake_engagements", 0) - values.get("brake_engagements_estop", 0)
    if faults > 0:
        braked = values.get("braked_s", 0.0) - values.get("braked_s_estop", 0.0)
        times = "once" if faults == 1 else f"{faults} times"
        reasons.append(f"the brakes held the arm {times} for a fault ({braked:.2f} s in all)")
    stops = {name: values.get(f"{name}_ticks", 0) for name in UNASKED_STOPS}
    if said := ", ".join(f"{name} {count}" for name, count in stops.items() if count):
        reasons.append(f"stops nobody asked for ({said} ticks)")
    return Verdict(tuple(reasons))


def _beyond(peaks: Sequence[float], band: float, names: list[str], units: list[str], what: str) -> list[str]:
    """One clause for the worst joint beyond the band, naming how many others are too."""
    over = [j for j, peak in enumerate(peaks) if peak > band]
    if not over:
        return []
    worst = max(over, key=lambda j: peaks[j])
    unit = units[worst] if worst < len(units) else "rad"
    milli = "mrad" if unit == "rad" else "mm"
    name = f" on {names[worst]}" if len(names) > 1 and worst < len(names) else ""
    others = f" (and {len(over) - 1} other joint(s))" if len(over) > 1 else ""
    return [
        f"{what} {peaks[worst] * 1e3:.3g} {milli}{name} off its reference, beyond its {band * 1e3:.3g} {milli} "
        f"tracking band{others}"
    ]


def _all_finite(values: Any) -> bool:
    return bool(values) and all(finite(v) for v in values)
