"""Every exercise by name, in the tutorial's order, as the CLI runs it
(``robot-controller exercise NAME --out DIR [--quick]``)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from robot_controller.experiments.exercises import disturbance, lqr, windup, ziegler_nichols


@dataclass(frozen=True)
class Exercise:
    name: str
    title: str  #: one line: what it does
    run: Callable[..., dict[str, Any]]  #: ``run(out, *, quick=False, progress=print) -> results``
    steps: Callable[[bool], int]  #: ``steps(quick)``: how many times ``run`` calls ``progress``


EXERCISES: dict[str, Exercise] = {
    name: Exercise(name, title, module.run, module.steps)
    for name, title, module in (
        ("tune", "tune the PID: Kp until it oscillates (Ku, Tu), then Kd, then Ki", ziegler_nichols),
        ("disturbance", "a 2 N·m step disturbance at t = 5 s: how far and how long", disturbance),
        ("windup", "saturation at 2 N·m: every anti-windup mode side by side on a 1 rad step", windup),
        ("lqr", "PID against LQR: gains, closed-loop poles and margins, sine and step", lqr),
    )
}
