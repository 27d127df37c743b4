"""ROS 2 parameter files: read (validated, naming the file, the key and the problem), layered (defaults, preset, the
user's files) and written."""

from __future__ import annotations

import difflib
from pathlib import Path
from typing import Any

import yaml

from robot_controller import resources
from robot_controller.core.errors import ConfigError
from robot_controller.core.laws import law_parameters as law_params
from robot_controller.parameters.schema import LOOP_WIDE, NODES, REPORTED, ROS_BUILTIN, SCHEMA, defaults, has, spec_of

Params = dict[str, dict[str, Any]]


def read_params_file(path: str | Path) -> Params:
    """A ROS 2 parameter file as ``{node: {param: value}}``, validated (``/**`` applies to every node); a
    ``ConfigError`` names the file, the key and the problem."""
    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text())
    except FileNotFoundError:
        raise ConfigError(f"{path}: no such file") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        raise ConfigError(f"{path}: expected a mapping of node names to 'ros__parameters'")
    out: Params = {}
    for key, body in raw.items():
        node = str(key).lstrip("/")
        if node != "**" and node not in NODES:
            hint = difflib.get_close_matches(node, NODES, n=1)
            suggestion = f" (did you mean {hint[0]!r}?)" if hint else ""
            raise ConfigError(f"{path}: unknown node {key!r}; nodes are {list(NODES)}{suggestion}")
        values = body.get("ros__parameters") if isinstance(body, dict) and set(body) == {"ros__parameters"} else None
        if not isinstance(values, dict):
            raise ConfigError(f"{path}: {key}: expected exactly one key 'ros__parameters' holding a mapping")
        for name, value in _flattened(values).items():
            if name in REPORTED:
                continue  # what a node reports (``param dump`` writes it), not a setting
            targets = [n for n in NODES if _has(n, name)] if node == "**" else [node]
            if node == "**" and not targets and name not in ROS_BUILTIN:
                raise ConfigError(f"{path}: /**.{name}: no node has a parameter {name!r}")
            for target in targets:
                out.setdefault(target, {})[name] = _validated(path, target, name, value)
            if node == "**" and name in ROS_BUILTIN:
                for target in NODES:
                    out.setdefault(target, {})[name] = value
    return out


def _flattened(values: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested mappings as dotted names, as rcl reads a parameter file: ``law: {kp: 1}`` is ``law.kp``."""
    out: dict[str, Any] = {}
    for key, value in values.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(_flattened(value, name + "."))
        else:
            out[name] = value
    return out


def _has(node: str, name: str) -> bool:
    """Whether ``node`` may have ``name``: in the schema, or a law's ``law.*`` (checked once the law is known)."""
    return has(node, name) or (node == law_params.NODE and law_params.is_law_key(name))


def _validated(path: Path, node: str, name: str, value: Any) -> Any:
    if law_params.is_law_key(name) and node == law_params.NODE:
        try:
            return law_params.plain_value(name, value)
        except ConfigError as exc:
            raise ConfigError(f"{path}: {node}.{exc}") from None
    if name in ROS_BUILTIN:
        if not isinstance(value, bool):
            raise ConfigError(f"{path}: {node}.{name}: expected true or false, got {value!r}")
        return value
    if not has(node, name):
        names = [spec.name for spec in SCHEMA[node]]
        hint = difflib.get_close_matches(name, names, n=1)
        suggestion = f" (did you mean {hint[0]!r}?)" if hint else f"; {node} has {names}"
        raise ConfigError(f"{path}: {node}.{name}: unknown parameter{suggestion}")
    try:
        return spec_of(node, name).validate(value)
    except ConfigError as exc:
        raise ConfigError(f"{path}: {node}.{exc}") from None


def merge(*layers: Params) -> Params:
    out: Params = {}
    for layer in layers:
        for node, values in layer.items():
            out.setdefault(node, {}).update(values)
    return out


def load_stack(
    preset: str = "default", config: str | Path | list[str | Path] | None = None, robot: str = "one_dof"
) -> Params:
    """The schema's defaults, then the robot's layer (its URDF, home pose and trajectory), the preset's overlay and the
    user's file(s), later over earlier. An empty ``torque_max`` is then written out as its node's URDF effort limits, so
    every check and the run's ``params.yaml`` see the numbers."""
    from robot_controller.parameters.torque_limits import fill_torque_limits
    from robot_controller.robots import robot as named_robot

    layers = [("the schema", defaults()), (f"--robot {robot}", named_robot(robot).layer())]
    files = []
    if preset != "default":
        preset_path = resources.preset_yaml(preset)
        if not preset_path.is_file():
            raise ConfigError(f"--preset: unknown preset {preset!r}; presets are {available_presets()}")
        files.append(preset_path)
    files += [] if config is None else config if isinstance(config, list) else [config]
    sources = [(Path(path), read_params_file(path)) for path in files]
    params = merge(*(layer for _, layer in layers), *(layer for _, layer in sources))
    check_complete(params)
    one_value_for_the_loop(params, [*layers, *((str(path), layer) for path, layer in sources)])
    # The law controller_type names: found (a file's path made absolute), its law.* values checked, defaults in.
    law_params.settle(params, sources)
    fill_torque_limits(params)
    return params


def one_value_for_the_loop(params: Params, layers: list[tuple[str, Params]]) -> None:
    """Each loop-wide parameter (``LOOP_WIDE``) set on every node that declares it, to the value of the last layer
    that sets it on any of them (a file that sets pid_controller's control_rate_hz sets the simulator's too);
    ``ConfigError`` if a layer (named ``where``, or "") gives two nodes different values."""
    for key, nodes in LOOP_WIDE.items():
        value = None
        for where, layer in layers:
            given = {node: layer[node][key] for node in nodes if key in layer.get(node, {})}
            if len({repr(v) for v in given.values()}) > 1:  # (a list's repr: lists are not hashable)
                said = " but ".join(
                    f"{node}.{key} {v:g}" if isinstance(v, float) else f"{node}.{key} {v}" for node, v in given.items()
                )
                prefix = f"{where}: " if where else ""
                raise ConfigError(f"{prefix}{said}: the loop has one {key}; set it once (on one node, or under /**)")
            value = next(iter(given.values()), value)
        for node in nodes:
            params[node][key] = value


def available_presets() -> list[str]:
    folder = resources.preset_yaml("default").parent
    return ["default"] + sorted(p.stem for p in folder.glob("*.yaml"))


def check_complete(params: Params) -> None:
    for node in NODES:
        missing = [spec.name for spec in SCHEMA[node] if spec.name not in params.get(node, {})]
        if missing:
            raise ConfigError(f"{node}: no value for {missing}")


def params_yaml(params: Params) -> str:
    """``params`` as the text of a ROS 2 parameter file."""
    body = {node: {"ros__parameters": dict(values)} for node, values in params.items()}
    return yaml.dump(body, Dumper=_NoAliasDumper, sort_keys=False, allow_unicode=True)


class _NoAliasDumper(yaml.SafeDumper):
    """Writes a value shared by two nodes twice: rcl's parameter-file parser refuses YAML anchors."""

    def ignore_aliases(self, data: Any) -> bool:
        return True


def write_params_file(params: Params, path: str | Path) -> Path:
    """``params`` as a ROS 2 parameter file that ``--params-file`` reads."""
    path = Path(path)
    path.write_text(params_yaml(params))
    return path
