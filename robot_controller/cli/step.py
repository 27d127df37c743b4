"""``robot-controller step``: a step response and its figures (overshoot, rise, settling, steady-state
error, torque), on the real graph."""

from __future__ import annotations

import argparse
import datetime as dt
import sys
from pathlib import Path

from robot_controller.cli.args import controller_option, out_option, stack_options, step_size_rad, verb
from robot_controller.cli.output import output_dir, print_table
from robot_controller.core.errors import ConfigError
from robot_controller.runner.options import RunOptions

STEP_HEADLINE = ("overshoot_pct", "rise_time_s", "settling_time_s", "steady_state_error_rad", "peak_torque_nm")


def register(sub) -> None:
    p = verb(sub, "step", "a step response: overshoot, rise, settling, steady-state error, torque", step)
    p.add_argument("--amplitude", type=step_size_rad, default=0.5, help="step size, rad (default 0.5)")
    p.add_argument(
        "--shaping",
        default="min_time",
        choices=("min_time", "none"),
        help="shape the step into the fastest move within the acceleration limit (default), or jump",
    )
    out_option(p, None)
    stack_options(p)
    controller_option(p)
    p.add_argument("--sim-time", action="store_true", help="deterministic lockstep")


def step(a: argparse.Namespace) -> int:
    from robot_controller.experiments import step as experiments
    from robot_controller.experiments.laws import with_controller

    options = RunOptions.from_args(a)
    params = with_controller(options.params(), a.controller)
    shape = {"amplitude": a.amplitude, "shaping": a.shaping}
    checked = experiments.check_step(params, **shape, sim_time=options.sim_time, seed=options.seed)  # before the folder
    out = output_dir(a.out, Path("runs") / ("step-" + dt.datetime.now().strftime("%Y%m%d-%H%M%S")))
    try:
        values = experiments.step_response(checked, out, **shape)
    except ConfigError:
        raise  # a user error: one line, exit 2
    except (RuntimeError, ValueError) as exc:
        print(f"robot-controller: {exc}", file=sys.stderr)
        return 1
    print_table(values, title=f"step {a.amplitude} rad ({a.shaping}) → {out}", headline=STEP_HEADLINE)
    return 0
