"""The reference pages ``docs/parameters.md`` and ``docs/cli.md``, written from the definitions themselves
(never argparse's formatted help, which depends on the terminal), and the verbs that show them: ``help``; ``params``
(every node parameter with its value and meaning, as a parameter file with ``--yaml``, or the reference page with
``--markdown``); ``robots`` (the arms ``--robot`` takes, a line each)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from robot_controller.cli.args import UsageError, stack_options, verb

PARAMS_COMMAND = "robot-controller params --markdown docs/parameters.md"
CLI_COMMAND = "robot-controller help --markdown docs/cli.md"


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return f'"{value}"' if value == "" else value
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    return repr(value)


def _kind(spec) -> str:
    name = {bool: "bool", int: "int", float: "float", str: "string"}[spec.kind]
    if spec.per_joint:
        name += " per joint"
    elif spec.length is not None:
        name = f"{spec.length} × {name}"
    return name + (", read-only" if spec.read_only else "")


def _accepted(spec) -> str:
    rules = spec.value_rules(markdown=True)
    if spec.allow_empty:
        rules.append("or empty")
    return "; ".join(rules)


def parameters_markdown() -> str:
    """Every node's parameters (type, default, accepted, meaning), then what each preset and ``--robot`` changes."""
    from robot_controller import parameters as cfg
    from robot_controller import resources
    from robot_controller.robots import DEFAULT_ROBOT, ROBOTS

    lines = [
        "# Parameters",
        "",
        f"<!-- Written by `{PARAMS_COMMAND}` from robot_controller/parameters; do not edit by hand. -->",
        "",
        "Every parameter of every node, as the schema declares it: each is a ROS parameter with this",
        "description and range. `robot-controller params` lists the values in force (with `--preset`,",
        "`--robot`, `--config`); `robot-controller params --yaml` writes them as a parameter file to start",
        "a `--config` from; `robot-controller param set NODE NAME VALUE` changes one on a running graph",
        "(read-only ones only at start). A per-joint value is one number for every joint or one per joint.",
        "A control law of one's own adds its parameters to `pid_controller` as `law.NAME`",
        "([own-controller.md](own-controller.md)).",
        "",
        "Nodes: " + ", ".join(f"[{node}](#{node})" for node in cfg.NODES) + "; [presets](#presets); [robots](#robots).",
    ]
    for node in cfg.NODES:
        lines += ["", f"## {node}", "", "| parameter | type | default | accepted | meaning |", "|---|---|---|---|---|"]
        for spec in cfg.SCHEMA[node]:
            lines.append(
                f"| `{spec.name}` | {_kind(spec)} | `{_value(spec.default)}` | {_cell(_accepted(spec))} "
                f"| {_cell(spec.description)} |"
            )
    lines += [
        "",
        "## Presets",
        "",
        "`--preset NAME` lays a preset over the defaults above (and under `--config`). `default` is the",
        "schema's defaults.",
    ]
    for preset in cfg.available_presets():
        if preset == "default":
            continue
        path = resources.preset_yaml(preset)
        lines += ["", f"### {preset}", "", f"`config/presets/{path.name}`:", "", "| node | parameter | value |"]
        lines.append("|---|---|---|")
        for node, values in cfg.read_params_file(path).items():
            lines += [f"| {node} | `{name}` | `{_value(value)}` |" for name, value in values.items()]
    lines += [
        "",
        "## Robots",
        "",
        f"`--robot NAME` lays the robot's values over the defaults (which are `{DEFAULT_ROBOT}`'s) and under the",
        "preset. An empty `torque_max` is each joint's URDF effort limit, whichever URDF a node is given.",
    ]
    for name, robot in ROBOTS.items():
        if name == DEFAULT_ROBOT:
            continue
        lines += ["", f"### {name}", "", robot.summary[0].upper() + robot.summary[1:] + ".", ""]
        lines += ["| node | parameter | value |", "|---|---|---|"]
        for node, values in robot.layer().items():
            for param, value in values.items():
                shown = "the robot's URDF" if param == "urdf_path" else f"`{_value(value)}`"
                lines.append(f"| {node} | `{param}` | {shown} |")
    return "\n".join(lines) + "\n"


def _metavar(action: argparse.Action) -> str:
    return str(action.metavar) if action.metavar is not None else action.dest.upper()


def _takes_value(action: argparse.Action) -> bool:
    return action.nargs != 0


def _usage(parser: argparse.ArgumentParser, prefix: str) -> str:
    words = [prefix]
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        if isinstance(action, argparse._SubParsersAction):
            words.append("{" + ",".join(action.choices) + "} ...")
            continue
        if not action.option_strings:
            name = _metavar(action)
            words.append(f"{name} [{name} ...]" if action.nargs == "+" else name)
            continue
        option = action.option_strings[-1]
        if _takes_value(action):
            option += f" [{_metavar(action)}]" if action.nargs == "?" else f" {_metavar(action)}"
        words.append(option if action.required else f"[{option}]")
    return " ".join(words)


def _default(action: argparse.Action) -> str:
    shown = _takes_value(action) and action.default not in (None, argparse.SUPPRESS)
    return f"`{action.default}`" if shown else ""


def subcommands(parser: argparse.ArgumentParser) -> list[tuple[str, str, argparse.ArgumentParser]]:
    """``(name, help, parser)`` of each subcommand, in declaration order."""
    out = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {choice.dest: choice.help for choice in action._choices_actions}
            out += [(name, helps.get(name) or "", sub) for name, sub in action.choices.items()]
    return out


def _verb_section(name: str, help_text: str, parser: argparse.ArgumentParser, prefix: str) -> list[str]:
    lines = ["", f"## {name}", "", _cell(help_text) + ".", "", "```", _usage(parser, prefix), "```"]
    subs = subcommands(parser)
    if subs:
        lines += ["", "| subcommand | what it does |", "|---|---|"]
        lines += [f"| [`{name} {sub}`](#{name}-{sub}) | {_cell(text)} |" for sub, text, _ in subs]
    rows = [action for action in parser._actions if not isinstance(action, argparse._HelpAction)]
    rows = [action for action in rows if not isinstance(action, argparse._SubParsersAction)]
    if rows:
        lines += ["", "| argument | default | meaning |", "|---|---|---|"]
        for action in rows:
            shown = ", ".join(action.option_strings) if action.option_strings else _metavar(action)
            if action.option_strings and _takes_value(action):
                shown += " " + _metavar(action)
            shown_help = action.help or ""
            if action.choices is not None:
                choices = ", ".join(f"`{c}`" for c in action.choices)
                shown_help += ("; " if action.help else "") + f"one of {choices}"
            lines.append(f"| `{_cell(shown)}` | {_default(action)} | {_cell(shown_help)} |")
    for sub, text, subparser in subs:
        lines += _verb_section(f"{name} {sub}", text, subparser, f"{prefix} {sub}")
    return lines


def cli_markdown(parser: argparse.ArgumentParser) -> str:
    """Every verb of ``parser``: what it does, its usage, its arguments with their defaults and help."""
    verbs = subcommands(parser)
    lines = [
        "# Command line",
        "",
        f"<!-- Written by `{CLI_COMMAND}` from robot_controller/cli/; do not edit by hand. -->",
        "",
        f"`{parser.prog} VERB [options]`: {parser.description}. Every verb also takes `-h`. A mistake on the",
        "command line is one line on stderr and exit code 2.",
        "",
        "| verb | what it does |",
        "|---|---|",
    ]
    lines += [f"| [`{name}`](#{name.replace(' ', '-')}) | {_cell(text)} |" for name, text, _ in verbs]
    for name, text, sub in verbs:
        lines += _verb_section(name, text, sub, f"{parser.prog} {name}")
    return "\n".join(lines) + "\n"


def write(text: str, path: str | None, verb: str) -> int:
    """``text`` to stdout (no path, or ``-``) or to ``path``, said on stderr."""
    if path in (None, "-"):
        sys.stdout.write(text)
        return 0
    target = Path(path)
    target.write_text(text)
    print(f"robot-controller {verb}: wrote {target}", file=sys.stderr)
    return 0


def register(sub, root: argparse.ArgumentParser) -> None:
    """``help [VERB]``: one verb's help, or every verb of ``root``."""
    p = verb(
        sub,
        "help",
        "a verb's options and help (every verb's without one)",
        lambda a: _help_verb(root, a.about, a.markdown),
    )
    p.add_argument("about", nargs="?", metavar="VERB", help="the verb to explain, as `VERB --help` does")
    p.add_argument(
        "--markdown",
        nargs="?",
        const="-",
        metavar="PATH",
        help="every verb as Markdown, to PATH or stdout (docs/cli.md)",
    )


def _help_verb(root: argparse.ArgumentParser, about: str | None, markdown: str | None) -> int:
    verbs = {name: sub for name, _, sub in subcommands(root)}
    if about is not None:
        if markdown is not None:
            raise UsageError("--markdown writes every verb's page: give no VERB with it")
        if about not in verbs:
            raise UsageError(f"no verb {about!r}; the verbs: {', '.join(verbs)}")
        print(verbs[about].format_help(), end="")
        return 0
    if markdown is not None:
        return write(cli_markdown(root), markdown, "help")
    print(root.format_help())
    for name, sub in verbs.items():
        print(f"--- {name} ---\n{sub.format_help()}")
    return 0


def register_params(sub) -> None:
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
