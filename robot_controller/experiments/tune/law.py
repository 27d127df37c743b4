"""``robot-controller tune --controller SPEC`` for a law of one's own (a plugin):
its parameters declared ``gain=True`` searched within their ``minimum`` and
``maximum``, on the in-process loop, under the built-in tune's margins where a
black box allows them.

A plugin law is a black box: there is no transfer function to take margins of,
and the batch harness (``core.batch``) runs the built-in PID only. So every
candidate runs the in-process loop (the lockstep graph's computation: MuJoCo
arm, sensor noise, the law), and the margins are measured there, as pushes
that must die away:

- **Objective**: the sine's tracking RMS (reference − true angle, after the 2 s
  warm-up) with the configured stack (its estimator included) and the sensor's
  noise; every candidate meets the same noise draws.
- **Robustness**, the built-in's margins (``margins``) as a black box shows them.
  A short push (``PUSH_FRACTION`` of each joint's torque limit for
  ``PUSH_PERIODS`` control periods, at ``PUSH_AT_S`` on the sine) is given to
  the loop, and the same run unpushed (the same sensor noise) is subtracted:
  what is left is the push's own effect (as in ``exercise disturbance``). A
  case passes if that effect has died down to ``DECAY_FRACTION`` (e⁻³) of its
  peak, or to ``DECAY_FLOOR_RAD``, by ``3 × MAX_TIME_CONSTANT_S`` after the
  push; neither run's torque reached the limit after the warm-up (an unstable
  loop swings into the limit, and then both runs swing alike); and the law did
  not fault. These runs are the configured loop, sensor noise and Kalman filter
  included, without the filter's disturbance observer (:data:`WITHOUT_OBSERVER`).
  The cases, checked in this order:

  * *delay*: the readings ``MIN_DELAY_PERIODS`` (2) control periods late and
    stamped on arrival, so nothing can compensate them: the delay margin;
  * *nominal*: as configured: the slowest closed-loop pole's time constant
    within ``MAX_TIME_CONSTANT_S`` (1 s), roughly;
  * *gain up*: the drive applies 2× (+6 dB) the command: the gain margin;
  * *gain down*: ½× (−6 dB): a loop that a lower gain (saturation) destabilises.

  Not checked: the phase margin (a black box has no crossover to measure it
  at; the delay case bounds the phase lost to delay), and gains beyond the
  two points ±6 dB. A candidate is checked only if it tracks better than the
  best robust one so far; the search keeps the best that passes.
- **Search**: a Latin hypercube over the declared ranges (log-scaled where a
  range is not negative and spans a decade or more; one from 0 from
  ``FROM_ZERO`` of its maximum), then rounds of samples around the best robust
  ones, narrower each round.
- **Check**: before and after, on another noise seed and a longer run; and the
  delay margin measured in whole periods (the most delay each survives).

Writes ``tuned.yaml`` (``controller_type`` and the ``law.NAME`` values, for
``--config``), ``tune.json`` (flat) and ``report.md``, ``tune.png``.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError
from robot_controller.core.laws import parameters as law_parameters
from robot_controller.core.laws import registry
from robot_controller.core.loop import Disturbance, LoopResult
from robot_controller.core.metrics import WARMUP_S
from robot_controller.experiments.tune.margins import MAX_TIME_CONSTANT_S, MIN_DELAY_PERIODS, MIN_GAIN_MARGIN_DB
from robot_controller.experiments.tune.problem import SEED
from robot_controller.experiments.tune.search import latin_hypercube
from robot_controller.parameters.limits import torque_limit
from robot_controller.scoring import report

PUSH_AT_S = 2.0  #: the push, s of the run (after the warm-up; the default sine's peak speed)
PUSH_FRACTION = 0.1  #: of each joint's torque limit
PUSH_PERIODS = 5  #: control periods it lasts
SETTLE_S = 3.0 * MAX_TIME_CONSTANT_S  #: it must have died away by then, s after the push
TAIL_S = 0.5  #: … over the last this many s of the run
DECAY_FRACTION = math.exp(-3.0)  #: of its peak: three time constants of MAX_TIME_CONSTANT_S
DECAY_FLOOR_RAD = 2e-4  #: or within this (the two runs' noise-driven wander)
SATURATED = 0.999  #: of the torque limit: a run that reaches it fails its case
GAIN_FACTOR = 10.0 ** (MIN_GAIN_MARGIN_DB / 20.0)  #: 6 dB: 2.0
DELAY_REPORTED_UP_TO = 8  #: periods: the delay margin reported, at most
CHECK_SEED = SEED + 1  #: the before/after check's noise, not the search's
#: A range from 0 to a maximum is searched on a log scale from this fraction of the maximum (a gain's useful
#: values span decades: a linear spread would put nearly every sample among the largest).
FROM_ZERO = 1e-4
#: The robustness cases run the configured loop without the Kalman filter's disturbance observer: the law
#: gets the filter's estimate as in the stack (on the raw readings, examples/simple_pid_law.py's derivative of
#: their 5 mrad noise saturated the torque with the drive's gain doubled), but a delay or a gain nothing
#: accounts for is a model mismatch the observer reads as a push and fights. With it, the default LQR's push
#: is 22 % left 3 s after it at two periods late, and with the drive's gain doubled its torque hits the
#: limit; without it, a push dies away at two periods (1 % left) and not at three (15 %), and in both gain
#: cases: the default meets every case, with the 2 periods its analytic margin gives (README, issue 12).
#: (The built-in margins are the law's and the arm's alone: neither filter nor observer.)
WITHOUT_OBSERVER = {"disturbance_observer": False}


@dataclass(frozen=True)
class Knob:
    """One searched parameter: its range, and whether the search spreads it on a log scale."""

    name: str
    low: float
    high: float
    log: bool

    def value(self, unit: np.ndarray) -> np.ndarray:
        """From [0, 1] to the range."""
        unit = np.clip(unit, 0.0, 1.0)
        if self.log:
            return self.low * (self.high / self.low) ** unit
        return self.low + unit * (self.high - self.low)

    def unit(self, value: float) -> float:
        """From the range to [0, 1]."""
        value = min(max(float(value), self.low), self.high)
        if self.high == self.low:
            return 0.0
        if self.log:
            return math.log(value / self.low) / math.log(self.high / self.low)
        return (value - self.low) / (self.high - self.low)


def knobs(law_class: type) -> tuple[Knob, ...]:
    """The parameters ``law_class`` lets tune search: declared ``gain=True``, numbers with a minimum and a maximum."""
    found = []
    for p in law_parameters.declared(law_class):
        if not p.gain:
            continue
        default = p.default[0] if isinstance(p.default, (list, tuple)) and p.default else p.default
        if isinstance(default, bool) or not isinstance(default, (int, float)):
            raise ConfigError(f"law.{p.name}: gain=True needs a number (tune searches it), not {p.default!r}")
        if p.minimum is None or p.maximum is None or not p.maximum > p.minimum:
            raise ConfigError(f"law.{p.name}: gain=True needs a minimum and a larger maximum (tune searches within)")
        low = p.minimum if p.minimum > 0 else p.maximum * FROM_ZERO  # a gain from 0: from a ten-thousandth
        if p.minimum >= 0 and p.maximum >= 10.0 * low:
            found.append(Knob(p.name, float(low), float(p.maximum), log=True))
        else:
            found.append(Knob(p.name, float(p.minimum), float(p.maximum), log=False))
    if not found:
        raise ConfigError(
            f"{law_class.__name__} declares no parameter with gain=True (and a minimum and maximum): "
            "nothing for tune to search"
        )
    return tuple(found)


@dataclass(frozen=True)
class Case:
    """One robustness case: the loop perturbed this way must still let a push die away."""

    name: str
    description: str
    delay_periods: int = 0
    actuator_gain: float = 1.0


#: In the order they are checked: the one that fails most often first.
CASES = (
    Case(
        "delay",
        f"readings {MIN_DELAY_PERIODS} control periods late, stamped on arrival (delay margin)",
        delay_periods=MIN_DELAY_PERIODS,
    ),
    Case("nominal", f"as configured (slowest pole within about {MAX_TIME_CONSTANT_S:g} s)"),
    Case("gain_up", f"the drive applies {GAIN_FACTOR:.3g}× the command (+{MIN_GAIN_MARGIN_DB:g} dB)", 0, GAIN_FACTOR),
    Case("gain_down", f"the drive applies {1 / GAIN_FACTOR:.3g}× (−{MIN_GAIN_MARGIN_DB:g} dB)", 0, 1 / GAIN_FACTOR),
)


@dataclass(frozen=True)
class LawPlan:
    first: int  #: Latin-hypercube samples of the first round
    rounds: tuple[tuple[int, float], ...]  #: (samples, σ of the spread around the best robust, fraction of the range)
    duration_s: float  #: each candidate's sine run, s (2 s warm-up included)
    max_checks: int  #: robustness checks per round at most (best tracking first)
    check_s: float  #: the before/after check's sine run, s


def plan(quick: bool) -> LawPlan:
    if quick:
        return LawPlan(first=16, rounds=((8, 0.12), (8, 0.05)), duration_s=4.0, max_checks=3, check_s=10.0)
    return LawPlan(first=48, rounds=((16, 0.15), (16, 0.07), (16, 0.03)), duration_s=10.0, max_checks=6, check_s=20.0)


def steps(quick: bool = False) -> int:
    """How many times :func:`tune_law` calls ``progress``: each search round, then the check."""
    return 1 + len(plan(quick).rounds) + 1


class LawProblem:
    """The configured stack with the law ``controller_type`` names, as the search sees it."""

    def __init__(self, params: cfg.Params) -> None:
        ctrl = params["pid_controller"]
        self.params = params
        self.spec = ctrl["controller_type"]
        self.law_class = registry.resolve(self.spec)
        self.knobs = knobs(self.law_class)
        self.dt = 1.0 / ctrl["control_rate_hz"]
        self.joint_count = int(params["trajectory_planner"]["joint_count"])
        self.torque_limit = torque_limit(params["motor_node"], self.joint_count)

    def current(self) -> np.ndarray:
        """The searched parameters' values in the stack (a per-joint list: its first value)."""
        ctrl = self.params["pid_controller"]
        declared = {p.name: p for p in law_parameters.declared(self.law_class)}
        out = []
        for knob in self.knobs:
            value = ctrl.get(law_parameters.PREFIX + knob.name, declared[knob.name].default)
            out.append(float(np.atleast_1d(np.asarray(value, dtype=float))[0]))
        return np.array(out)

    def overlay(self, values: np.ndarray) -> dict[str, Any]:
        """The ``pid_controller`` parameters that set these values (one for every joint)."""
        return {law_parameters.PREFIX + k.name: float(v) for k, v in zip(self.knobs, values, strict=True)}

    def with_values(self, values: np.ndarray, without_observer: bool = False) -> cfg.Params:
        """The stack with these values; ``without_observer``: no disturbance observer (:data:`WITHOUT_OBSERVER`)."""
        extra = WITHOUT_OBSERVER if without_observer else {}
        return cfg.merge(self.params, {"pid_controller": self.overlay(values) | extra})

    def run(
        self, values: np.ndarray, duration_s: float, seed: int, without_observer: bool = False, **options: Any
    ) -> LoopResult | None:
        """The in-process loop with these values (None if the law refuses them at start)."""
        from robot_controller.experiments import inprocess

        try:
            return inprocess.simulate(
                self.with_values(values, without_observer), duration_s=duration_s, seed=seed, **options
            )
        except ConfigError:  # e.g. a design the law itself refuses for these values
            return None

    def tracking_rms(self, values: np.ndarray, duration_s: float, seed: int = SEED) -> float:
        """The sine's tracking RMS (true angle, after the warm-up), rad; ∞ if the law faulted or refused."""
        result = self.run(values, duration_s, seed)
        if result is None or result.law_fault is not None:
            return math.inf
        rms = float(result.tracking_metrics()["tracking_rms_rad"])
        return rms if math.isfinite(rms) else math.inf

    def push_decay(self, values: np.ndarray, case: Case, seed: int = SEED) -> dict[str, float]:
        """The push's own effect in ``case``: its peak and what is left at the end (rad), and whether it died away."""
        options = {
            "measurement_delay_s": case.delay_periods * self.dt,
            "delay_unstamped": case.delay_periods > 0,
            "actuator_gain": case.actuator_gain,
        }
        duration_s = PUSH_AT_S + SETTLE_S
        push = Disturbance(PUSH_FRACTION * self.torque_limit, PUSH_AT_S, PUSH_PERIODS * self.dt)
        plain = self.run(values, duration_s, seed, without_observer=True, **options)
        pushed = self.run(values, duration_s, seed, without_observer=True, disturbance=push, **options)
        failed = {"peak_rad": math.nan, "left_rad": math.nan, "left_fraction": math.nan, "saturated": 1, "ok": False}
        if plain is None or pushed is None or plain.law_fault or pushed.law_fault:
            return failed
        t = pushed.tick_time_s
        # An unstable loop grows until the torque saturates, and then both runs swing in the same limit
        # cycle: their difference would say nothing. So neither may reach the limit after the warm-up.
        scored = t >= WARMUP_S
        saturated = any(
            bool(np.any(np.abs(run.applied[scored]) >= SATURATED * self.torque_limit)) for run in (plain, pushed)
        )
        effect = np.max(np.abs(pushed.true_position - plain.true_position), axis=1)
        peak = float(np.max(effect[t >= PUSH_AT_S]))
        left = float(np.max(effect[t >= t[-1] - TAIL_S + 1e-9]))
        if not (math.isfinite(peak) and math.isfinite(left)):
            return failed
        return {
            "peak_rad": peak,
            "left_rad": left,
            "left_fraction": left / peak if peak > 0 else 0.0,
            "saturated": int(saturated),
            "ok": left <= max(DECAY_FRACTION * peak, DECAY_FLOOR_RAD) and not saturated,
        }

    def robust(self, values: np.ndarray, seed: int = SEED) -> bool:
        """Every case passes (stops at the first that does not)."""
        return all(self.push_decay(values, case, seed)["ok"] for case in CASES)

    def delay_margin(self, values: np.ndarray, seed: int = SEED, up_to: int = DELAY_REPORTED_UP_TO) -> int:
        """The most whole control periods of unstamped delay after which a push still dies away (0 … ``up_to``)."""
        for periods in range(1, up_to + 1):
            if not self.push_decay(values, Case("delay", "", delay_periods=periods), seed)["ok"]:
                return periods - 1
        return up_to


@dataclass
class LawSearch:
    problem: LawProblem
    best_values: np.ndarray  #: as written (4 significant figures)
    best_rms: float  #: rad, on the search's runs
    evaluated: int  #: candidates run
    checked: int  #: … whose robustness was checked
    robust: int  #: … of which passed every case
    rounds: list[dict[str, float]]
    history: list[tuple[np.ndarray, float, bool | None]] = field(default_factory=list)  #: values, RMS, robust?


def search(
    problem: LawProblem, *, quick: bool = False, progress: Callable[[str], None] | None = None, seed: int = SEED
) -> LawSearch:
    """The best-tracking values that pass every robustness case, among those run."""
    settings = plan(quick)
    rng = np.random.default_rng(seed)
    unit_box = {k.name: (0.0, 1.0) for k in problem.knobs}
    best_units, best_rms = None, math.inf
    robust_units: list[tuple[float, np.ndarray]] = []
    history: list[tuple[np.ndarray, float, bool | None]] = []
    rounds: list[dict[str, float]] = []
    evaluated = checked = robust_count = 0
    schedule = [(settings.first, None), *settings.rounds]
    for index, (samples, spread) in enumerate(schedule):
        if progress is not None:
            progress(
                f"search round {index + 1} of {len(schedule)}: {samples} candidates on the in-process loop"
                + ("" if spread is None else f" around the best robust (σ {spread:g} of each range)")
            )
        if spread is None or not robust_units:
            units = latin_hypercube(rng, samples, unit_box)
            if index == 0:  # the configured values compete too
                units[0] = [k.unit(v) for k, v in zip(problem.knobs, problem.current(), strict=True)]
        else:
            centres = np.array([u for _, u in sorted(robust_units, key=lambda r: r[0])[:3]])
            picked = centres[rng.integers(0, len(centres), samples)]
            units = np.clip(picked + rng.normal(0.0, spread, picked.shape), 0.0, 1.0)
        values = _values(problem, units)
        rms = np.array([problem.tracking_rms(v, settings.duration_s, seed) for v in values])
        evaluated += samples
        verdicts: list[bool | None] = [None] * samples
        cap = settings.max_checks if robust_units else samples  # none robust yet: down the whole round
        for i in np.argsort(rms)[:cap]:
            if not rms[i] < best_rms:
                break  # no better than the best robust: not worth its checks
            checked += 1
            verdicts[i] = problem.robust(values[i], seed)
            if verdicts[i]:
                robust_count += 1
                robust_units.append((float(rms[i]), units[i]))
                best_units, best_rms = units[i], float(rms[i])
                break  # the round's best robust one: the others track worse
        history += [(v, float(r), ok) for v, r, ok in zip(values, rms, verdicts, strict=True)]
        rounds.append({"samples": samples, "best_rms_rad": best_rms})
    if best_units is None:
        raise RuntimeError(
            f"tune: no candidate for {problem.spec} let a push die away in every case "
            f"({', '.join(c.name for c in CASES)}); see the law's ranges"
        )
    exact = _values(problem, best_units[None])[0]
    best_values = np.array([_round(v) for v in exact])  # as the parameter file gets them
    if not problem.robust(best_values, seed):  # rounding moved it across a case's edge: keep the exact values
        best_values = exact
    return LawSearch(problem, best_values, best_rms, evaluated, checked, robust_count, rounds, history)


def _values(problem: LawProblem, units: np.ndarray) -> np.ndarray:
    units = np.atleast_2d(units)
    return np.column_stack([k.value(units[:, j]) for j, k in enumerate(problem.knobs)])


def _round(value: float, digits: int = 4) -> float:
    if value == 0 or not math.isfinite(value):
        return float(value)
    return float(round(value, digits - 1 - int(math.floor(math.log10(abs(value))))))


def describe(problem: LawProblem, values: np.ndarray, duration_s: float, check_s: float) -> dict[str, Any]:
    """Everything the report says of one set of values: each case, the delay margin, the RMS."""
    out: dict[str, Any] = {k.name: float(v) for k, v in zip(problem.knobs, values, strict=True)}
    meets = True
    for case in CASES:
        decay = problem.push_decay(values, case)
        out.update({f"{case.name}_{key}": value for key, value in decay.items() if key != "ok"})
        out[f"{case.name}_ok"] = int(decay["ok"])
        meets &= decay["ok"]
    out["meets_constraints"] = int(meets)
    out["delay_margin_periods"] = problem.delay_margin(values)
    out["search_rms_rad"] = problem.tracking_rms(values, duration_s, SEED)
    out["check_rms_rad"] = problem.tracking_rms(values, check_s, CHECK_SEED)
    return out


def tune_law(
    params: cfg.Params, out: Path, *, quick: bool = False, progress: Callable[[str], None] = print, seed: int = SEED
) -> dict[str, Any]:
    """Search, then check before and after; write ``tuned.yaml``, ``tune.json``, ``report.md`` and ``tune.png``."""
    started = time.perf_counter()
    problem = LawProblem(params)
    settings = plan(quick)
    out.mkdir(parents=True, exist_ok=True)
    result = search(problem, quick=quick, progress=progress, seed=seed)
    search_s = time.perf_counter() - started
    progress(f"check: before and after, {settings.check_s:g} s on noise seed {CHECK_SEED}, and the delay margins")
    before = describe(problem, problem.current(), settings.duration_s, settings.check_s)
    after = describe(problem, result.best_values, settings.duration_s, settings.check_s)
    overlay = {"controller_type": problem.spec} | problem.overlay(result.best_values)
    tuned_path = out / "tuned.yaml"
    cfg.write_params_file({"pid_controller": overlay}, tuned_path)
    tuned_path.write_text(_yaml_header(problem, result) + tuned_path.read_text())
    values: dict[str, Any] = {
        "quick": int(quick),
        "seed": seed,
        "check_seed": CHECK_SEED,
        "controller_type": problem.spec,
        "searched": ",".join(k.name for k in problem.knobs),
        "search_wall_s": search_s,
        "candidates_evaluated": result.evaluated,
        "candidates_checked": result.checked,
        "candidates_robust": result.robust,
        "search_duration_s": settings.duration_s,
        "check_duration_s": settings.check_s,
        "min_delay_margin_periods": MIN_DELAY_PERIODS,
        "gain_factor": GAIN_FACTOR,
        "max_time_constant_s": MAX_TIME_CONSTANT_S,
    }
    values |= {f"before_{k}": v for k, v in before.items()} | {f"after_{k}": v for k, v in after.items()}
    values["wall_s"] = time.perf_counter() - started
    report.write_metrics(out / "tune.json", values)
    _plot(out / "tune.png", result, problem.current())
    (out / "report.md").write_text(_report(values, problem, result, quick))
    return report.json_safe(values)


def _yaml_header(problem: LawProblem, result: LawSearch) -> str:
    return (
        f"# robot-controller tune --controller: {', '.join(k.name for k in problem.knobs)} of {problem.spec}, "
        f"chosen on the in-process loop (sine RMS {result.best_rms:.3g} rad) where a push still dies away "
        f"within {SETTLE_S:g} s with the readings {MIN_DELAY_PERIODS} periods late, with the drive's gain "
        f"±{MIN_GAIN_MARGIN_DB:g} dB, and as configured.\n"
        "# Use over the same preset and files it was tuned with: "
        "robot-controller run [--preset P] [--config F ...] --config tuned.yaml\n"
    )


def _plot(path: Path, result: LawSearch, before: np.ndarray) -> None:
    from robot_controller.experiments.exercises.common import pyplot

    plt = pyplot()
    knob_list = result.problem.knobs
    fig, axes = plt.subplots(1, len(knob_list), figsize=(4.5 * len(knob_list), 4), constrained_layout=True)
    axes = np.atleast_1d(axes)
    values = np.array([v for v, _, _ in result.history])
    rms = np.array([r for _, r, _ in result.history])
    verdict = [ok for _, _, ok in result.history]
    finite = np.isfinite(rms)
    for j, (ax, knob) in enumerate(zip(axes, knob_list, strict=True)):
        for label, mask, style in (
            ("not checked", [ok is None for ok in verdict], dict(c="0.6", s=8)),
            ("failed a case", [ok is False for ok in verdict], dict(c="tab:red", marker="x", s=30)),
            ("passed every case", [ok is True for ok in verdict], dict(c="tab:green", s=30)),
        ):
            mask = np.array(mask) & finite
            if np.any(mask):
                ax.scatter(values[mask, j], rms[mask] * 1e3, label=label, **style)
        ax.axvline(before[j], color="k", ls="--", lw=0.8, label="before")
        ax.axvline(result.best_values[j], color="tab:green", lw=1.2, label="after")
        ax.set_xscale("log" if knob.log else "linear")
        ax.set_yscale("log")
        ax.set_xlabel(knob.name)
        ax.set_ylabel("sine RMS, in process [mrad]")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"tune --controller {result.problem.spec}: every candidate run")
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _report(values: dict[str, Any], problem: LawProblem, result: LawSearch, quick: bool) -> str:
    def f(value: Any, spec: str = "{:.3g}") -> str:
        if value is None or (isinstance(value, float) and not math.isfinite(value)):
            return "—"
        return spec.format(value)

    def cell(name: str, case: Case) -> str:
        ok = values[f"{name}_{case.name}_ok"]
        if values[f"{name}_{case.name}_saturated"]:
            return "**no** (saturated)"
        left = values[f"{name}_{case.name}_left_fraction"]
        return ("yes" if ok else "**no**") + f" ({f(left * 100 if left == left else None, '{:.1f}')} %)"

    headers = [
        "",
        *[k.name for k in problem.knobs],
        *[c.name.replace("_", " ") + ": dies away (left)" for c in CASES],
        "delay margin [periods]",
        "meets every case",
        "sine RMS, search [mrad]",
        "sine RMS, check [mrad]",
    ]
    rows = []
    for name in ("before", "after"):
        rows.append(
            [
                f"**{name}**",
                *[f(values[f"{name}_{k.name}"], "{:.4g}") for k in problem.knobs],
                *[cell(name, c) for c in CASES],
                str(values[f"{name}_delay_margin_periods"])
                + ("+" if values[f"{name}_delay_margin_periods"] == DELAY_REPORTED_UP_TO else ""),
                "yes" if values[f"{name}_meets_constraints"] else "**no**",
                f(values[f"{name}_search_rms_rad"] * 1e3, "{:.3f}"),
                f(values[f"{name}_check_rms_rad"] * 1e3, "{:.3f}"),
            ]
        )
    table = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    table += ["| " + " | ".join(row) + " |" for row in rows]
    ranges = ", ".join(f"{k.name} {k.low:g}…{k.high:g}" + (" (log)" if k.log else "") for k in problem.knobs)
    before, after = values["before_check_rms_rad"], values["after_check_rms_rad"]
    change = (
        f"from {before * 1e3:.3f} to {after * 1e3:.3f} mrad"
        if math.isfinite(before) and math.isfinite(after)
        else f"{f(before * 1e3)} → {f(after * 1e3)} mrad"
    )
    lines = [
        "# Automatic gain design: a law of one's own",
        "",
        f"Controller type **{problem.spec}**. Searched: its parameters declared `gain=True`, within their "
        f"ranges: {ranges}; one value for every joint." + (" **Quick form**: a smaller search." if quick else ""),
        "",
        f"The law is a black box, so each candidate ran the in-process loop (the lockstep graph's computation, no "
        f"ROS; the batch harness runs the built-in PID only): {result.evaluated} candidates, "
        f"{values['search_duration_s']:g} s of the sine each with the sensor's noise (seed {values['seed']}, "
        f"the same for all; the first 2 s not scored), in {len(result.rounds)} rounds (a Latin hypercube, then "
        f"samples around the best robust, narrower each round); {values['search_wall_s']:.1f} s in all.",
        "",
        "Robustness, measured (the built-in tune's margins as a black box shows them), on the configured loop "
        "without the Kalman filter's disturbance observer (it reads an unknown delay or gain as a push and fights "
        "it; the built-in margins are the law's and the arm's alone): a push of "
        f"{PUSH_FRACTION * 100:g} % of each joint's torque limit for {PUSH_PERIODS} control periods at "
        f"{PUSH_AT_S:g} s, its own effect taken against the same run unpushed (the same noise draws), must die "
        f"down to {DECAY_FRACTION * 100:.0f} % of its peak (or {DECAY_FLOOR_RAD * 1e3:g} mrad) within "
        f"{SETTLE_S:g} s, about a slowest time constant of {MAX_TIME_CONSTANT_S:g} s, in each case: "
        + "; ".join(f"*{c.name.replace('_', ' ')}*: {c.description}" for c in CASES)
        + f". {result.checked} candidates, the best-tracking first, were checked; {result.robust} passed. Not "
        "checked: the phase margin (no crossover to measure on a black box; the delay case bounds the phase "
        "lost to delay) and gains beyond ±6 dB.",
        "",
        *table,
        "",
        f"*Left*: the push's own effect over the last {TAIL_S:g} s, as a share of its peak; *saturated*: the "
        "torque reached its limit after the warm-up (an unstable loop's swing; both runs would then swing alike)."
        " *Delay margin*: the most whole control periods of unstamped delay after which the push still dies "
        "away (checked up to "
        f"{DELAY_REPORTED_UP_TO}). *Check*: {values['check_duration_s']:g} s of the sine on another noise seed "
        f"({values['check_seed']}): {change}.",
        "",
        f"Use it: `robot-controller run --config {Path('tuned.yaml')}` over the same preset and files (it sets "
        "controller_type too). Plot: `tune.png` (every candidate's tracking error, by parameter).",
        "",
    ]
    return "\n".join(lines)
