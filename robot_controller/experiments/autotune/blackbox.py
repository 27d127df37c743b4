"""``tune`` of a law of one's own: a black box, so each candidate runs the in-process loop and the
built-in margins are measured there: a push (:data:`PUSH_FRACTION` of the torque limit) must die away
within :data:`SETTLE_S` in every case (:data:`CASES`). Searched: its ``gain=True`` parameters (:class:`Knob`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller import parameters as cfg
from robot_controller.blocks.wiring import LoopResult
from robot_controller.core.errors import ConfigError
from robot_controller.core.laws import law_parameters, registry
from robot_controller.core.metrics import WARMUP_S
from robot_controller.experiments.autotune.margins import MAX_TIME_CONSTANT_S, MIN_DELAY_PERIODS, MIN_GAIN_MARGIN_DB
from robot_controller.experiments.autotune.search import FAILED, ROBUST, SEED, UNCHECKED, SearchPlan, SearchResult
from robot_controller.experiments.inprocess import Disturbance
from robot_controller.parameters.torque_limits import torque_limit

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
#: gets the filter's estimate as in the stack, but a delay or a gain nothing accounts for is a model mismatch
#: the observer reads as a push and fights. (The built-in margins are the law's and the arm's alone.)
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
class RobustnessCase:
    """One robustness case: the loop perturbed this way must still let a push die away."""

    name: str
    description: str
    delay_periods: int = 0
    actuator_gain: float = 1.0


#: In the order they are checked: the one that fails most often first.
CASES = (
    RobustnessCase(
        "delay",
        f"readings {MIN_DELAY_PERIODS} control periods late, stamped on arrival (delay margin)",
        delay_periods=MIN_DELAY_PERIODS,
    ),
    RobustnessCase("nominal", f"as configured (slowest pole within about {MAX_TIME_CONSTANT_S:g} s)"),
    RobustnessCase(
        "gain_up", f"the drive applies {GAIN_FACTOR:.3g}× the command (+{MIN_GAIN_MARGIN_DB:g} dB)", 0, GAIN_FACTOR
    ),
    RobustnessCase(
        "gain_down", f"the drive applies {1 / GAIN_FACTOR:.3g}× (−{MIN_GAIN_MARGIN_DB:g} dB)", 0, 1 / GAIN_FACTOR
    ),
)


class BlackBoxProblem:
    """The configured stack and its law, as the search sees them (coordinates: each knob's range mapped to [0, 1])."""

    centres = 3
    check_steps = 1  #: progress steps after the search: the check before and after

    def __init__(self, params: cfg.Params) -> None:
        ctrl = params["pid_controller"]
        self.params = params
        self.spec = ctrl["controller_type"]
        self.law_class = registry.resolve(self.spec)
        self.knobs = knobs(self.law_class)
        self.dt = 1.0 / ctrl["control_rate_hz"]
        self.joint_count = int(params["trajectory_planner"]["joint_count"])
        self.torque_limit = torque_limit(params["motor_node"], self.joint_count)
        self.low = self.clip_low = np.zeros(len(self.knobs))
        self.high = self.clip_high = np.ones(len(self.knobs))

    @staticmethod
    def plan(quick: bool) -> SearchPlan:
        if quick:
            return SearchPlan(first=16, rounds=((8, 0.12), (8, 0.05)), duration_s=4.0, check_s=10.0, max_checks=3)
        return SearchPlan(
            first=48, rounds=((16, 0.15), (16, 0.07), (16, 0.03)), duration_s=10.0, check_s=20.0, max_checks=6
        )

    def round_text(self, samples: int, spread: float | None) -> str:
        return f"{samples} candidates on the in-process loop" + (
            "" if spread is None else f" around the best robust (σ {spread:g} of each range)"
        )

    def start(self) -> np.ndarray:
        return np.array([k.unit(v) for k, v in zip(self.knobs, self.current(), strict=True)])

    def values(self, points: np.ndarray) -> np.ndarray:
        points = np.atleast_2d(points)
        return np.column_stack([k.value(points[:, j]) for j, k in enumerate(self.knobs)])

    def evaluate(
        self, values: np.ndarray, plan: SearchPlan, seed: int, best_rms: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Run every candidate; check the best-tracking ones, in order, until one is robust."""
        rms = np.array([self.tracking_rms(v, plan.duration_s, seed) for v in values])
        verdict = np.full(len(values), UNCHECKED)
        cap = plan.max_checks if math.isfinite(best_rms) else len(values)  # none robust yet: the whole round
        for i in np.argsort(rms)[:cap]:
            if not rms[i] < best_rms:
                break  # no better than the best robust: not worth its checks
            verdict[i] = ROBUST if self.robust(values[i], seed) else FAILED
            if verdict[i] == ROBUST:
                break  # the round's best robust one: the others track worse
        return rms, verdict, values

    def nothing_robust(self) -> str:
        return (
            f"tune: no candidate for {self.spec} let a push die away in every case "
            f"({', '.join(c.name for c in CASES)}); see the law's ranges"
        )

    def current(self) -> np.ndarray:
        """The searched parameters' values in the stack (a per-joint list: its first value)."""
        ctrl = self.params["pid_controller"]
        declared = {p.name: p for p in law_parameters.declared(self.law_class)}
        values = (ctrl.get(law_parameters.PREFIX + k.name, declared[k.name].default) for k in self.knobs)
        return np.array([float(np.atleast_1d(np.asarray(value, dtype=float))[0]) for value in values])

    def overlay(self, values: np.ndarray) -> dict[str, Any]:
        """The ``pid_controller`` parameters that set these values (one for every joint)."""
        return {law_parameters.PREFIX + k.name: float(v) for k, v in zip(self.knobs, values, strict=True)}

    def tuned_overlay(self, values: np.ndarray) -> dict[str, Any]:
        """``tuned.yaml``'s ``pid_controller`` parameters: the law and these values."""
        return {"controller_type": self.spec} | self.overlay(values)

    def run(
        self, values: np.ndarray, duration_s: float, seed: int, without_observer: bool = False, **options: Any
    ) -> LoopResult | None:
        """The in-process loop with these values (None if the law refuses them at start); ``without_observer``: no
        disturbance observer (:data:`WITHOUT_OBSERVER`)."""
        from robot_controller.experiments import inprocess

        overlay = self.overlay(values) | (WITHOUT_OBSERVER if without_observer else {})
        params = cfg.merge(self.params, {"pid_controller": overlay})
        try:
            return inprocess.simulate(params, duration_s=duration_s, seed=seed, **options)
        except ConfigError:  # e.g. a design the law itself refuses for these values
            return None

    def tracking_rms(self, values: np.ndarray, duration_s: float, seed: int = SEED) -> float:
        """The sine's tracking RMS (true angle, after the warm-up), rad; ∞ if the law faulted or refused."""
        result = self.run(values, duration_s, seed)
        if result is None or result.law_fault is not None:
            return math.inf
        rms = float(result.tracking_metrics()["tracking_rms_rad"])
        return rms if math.isfinite(rms) else math.inf

    def push_decay(self, values: np.ndarray, case: RobustnessCase, seed: int = SEED) -> dict[str, float]:
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
        # Saturated runs swing in the same limit cycle, their difference saying nothing: neither may saturate.
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

    passes = robust

    def delay_margin(self, values: np.ndarray, seed: int = SEED, up_to: int = DELAY_REPORTED_UP_TO) -> int:
        """The most whole control periods of unstamped delay after which a push still dies away (0 … ``up_to``)."""
        for periods in range(1, up_to + 1):
            if not self.push_decay(values, RobustnessCase("delay", "", delay_periods=periods), seed)["ok"]:
                return periods - 1
        return up_to


def describe(problem: BlackBoxProblem, values: np.ndarray, plan: SearchPlan) -> dict[str, Any]:
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
    out["search_rms_rad"] = problem.tracking_rms(values, plan.duration_s, SEED)
    out["check_rms_rad"] = problem.tracking_rms(values, plan.check_s, CHECK_SEED)
    return out


def before_after(
    problem: BlackBoxProblem,
    result: SearchResult,
    plan: SearchPlan,
    *,
    seed: int,
    out: Path,
    progress: Callable[[str], None],
) -> dict[str, Any]:
    """``tune.json``'s figures: the candidates checked, and each case, the delay margin and the RMS before and after."""
    progress(f"check: before and after, {plan.check_s:g} s on noise seed {CHECK_SEED}, and the delay margins")
    before = describe(problem, problem.current(), plan)
    after = describe(problem, result.best_values, plan)
    values: dict[str, Any] = {"check_seed": CHECK_SEED, "controller_type": problem.spec}
    values.update(searched=",".join(k.name for k in problem.knobs), candidates_checked=result.checked)
    values.update(search_duration_s=plan.duration_s, check_duration_s=plan.check_s)
    values.update(min_delay_margin_periods=MIN_DELAY_PERIODS, gain_factor=GAIN_FACTOR)
    values["max_time_constant_s"] = MAX_TIME_CONSTANT_S
    return values | {f"before_{k}": v for k, v in before.items()} | {f"after_{k}": v for k, v in after.items()}
