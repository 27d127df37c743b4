"""``robot-controller params``: every node parameter with its value and meaning, as a parameter file (``--yaml``), or
the schema's reference page (``--markdown``); ``robot-controller robots``: the arms ``--robot`` takes, a line each."""

from __future__ import annotations

import argparse

from robot_controller.cli.args import UsageError, stack_options, verb


def register(sub) -> None:
    p = verb(sub, "params", "list every node parameter with its default and meaning", _params)
    p.add_argument(
        "--yaml", action="store_true", help="print the values as a ROS 2 parameter file (for --config or --params-file)"
    )
    p.add_argument(
        "--markdown",
        nargs="?",
        const="-",
        metavar="PATH",
        help="write the reference of every parameter (the schema's, the presets' and robots' changes) as Markdown, "
        "to PATH or stdout (docs/parameters.md)",
    )
    stack_options(p, seed=False)
    robots_help = "list the arms --robot takes by name: joints, ranges (rad, m for a prismatic joint) and home pose"
    verb(sub, "robots", robots_help, _robots)


def _params(a: argparse.Namespace) -> int:
    from robot_controller import parameters as cfg
    from robot_controller.parameters.law_params import node_specs
    from robot_controller.robots import DEFAULT_ROBOT

    if a.markdown is None:
        values = cfg.load_stack(a.preset, a.config, a.robot)
        if a.yaml:
            print(cfg.params_yaml(values), end="")
            return 0
        for node in cfg.NODES:
            print(f"{node}:")
            for spec in node_specs(node, values[node]):
                read_only = " (read-only)" if spec.read_only else ""
                print(f"  {spec.name} = {values[node][spec.name]!r}: {spec.describe()}{read_only}")
        return 0
    if a.yaml or a.config or a.preset != "default" or a.robot != DEFAULT_ROBOT:
        raise UsageError("--markdown documents the schema: it takes no --yaml, --preset, --robot or --config")
    from robot_controller.cli.docs import parameters_markdown, write

    return write(parameters_markdown(), a.markdown, "params")


def _robots(_: argparse.Namespace) -> int:
    from robot_controller.core.errors import ConfigError
    from robot_controller.core.model.joint_limits import joint_limits
    from robot_controller.core.model.mujoco_model import joint_units, load_model
    from robot_controller.robots import ROBOTS, robot, urdf_of
    from robot_controller.robots.description import ARMS

    for name in sorted(set(ROBOTS) | set(ARMS)):
        try:
            limits, home = joint_limits(urdf_of(name)), robot(name).home_position
            units = joint_units(load_model(urdf_of(name)))
        except ConfigError as exc:  # example-robot-data missing, or an arm this MuJoCo refuses
            print(f"{name:<15} cannot run: {exc}")
            continue
        ranges = " ".join(
            f"{lo:.2f}..{hi:.2f}" + " m" * (unit == "m")
            for lo, hi, unit in zip(limits.lower, limits.upper, units, strict=True)
        )
        print(f"{name:<15} {len(home)} joints  range {ranges}  home {' '.join(f'{q:.2f}' for q in home)}")
    print("also: a URDF or MJCF path, package://pkg/path/arm.urdf, or another example-robot-data URDF's file name")
    return 0
