"""``param list | get | set | dump``: ros2cli's ``ros2 param`` verbs against any node on the domain, through the
rcl_interfaces parameter services. ``set`` reads the value as YAML, as ``ros2 param set`` does, but sends a number (or
list) as a double (array) where the node's value is one: ``kp 60`` sends ``[60.0]`` and the parameter keeps its type."""

from __future__ import annotations

import difflib
import sys
from typing import Any

from robot_controller.tools import graph
from robot_controller.tools.graph import ToolError

INTERRUPTED = 130  # Ctrl-C before the node answered: the change may or may not have been made

# rcl_interfaces/msg/ParameterType's constants: parsing needs no ROS import.
NOT_SET, BOOL, INTEGER, DOUBLE, STRING = 0, 1, 2, 3, 4
BYTE_ARRAY, BOOL_ARRAY, INTEGER_ARRAY, DOUBLE_ARRAY, STRING_ARRAY = 5, 6, 7, 8, 9

_KINDS = "bool integer double string byte_array bool_array integer_array double_array string_array".split()
_FIELDS = {kind: f"{name}_value" for kind, name in enumerate(_KINDS, start=BOOL)}
# What `ros2 param get` says before the value: "Boolean array value is:".
_LABELS = {
    kind: name.replace("bool", "boolean").replace("_", " ").capitalize() + " value is:"
    for kind, name in enumerate(_KINDS, start=BOOL)
}


def parse_value(text: str, current: int | None = None) -> tuple[int, Any]:
    """``(ParameterType, value)`` for what the user typed; ``current`` (the node's type, or None) keeps doubles."""
    import yaml

    try:
        value = yaml.safe_load(text)
    except yaml.YAMLError:
        value = text
    floating = current in (DOUBLE, DOUBLE_ARRAY)
    if floating:
        value = _as_float(value)  # YAML 1.1 reads 1e3 as a string; a number is meant here
    if isinstance(value, list) and (floating or any(_is_number(v) for v in value)):
        value = [_as_float(v) for v in value]  # [1e4, 1e4, 1]: YAML 1.1 reads the 1e4s as strings
    if isinstance(value, bool):
        return BOOL, value
    if isinstance(value, int | float):
        if current == DOUBLE_ARRAY:
            return DOUBLE_ARRAY, [float(value)]
        if isinstance(value, int) and not floating:
            return INTEGER, value
        return DOUBLE, float(value)
    if isinstance(value, list):
        if not value and current in (BYTE_ARRAY, BOOL_ARRAY, INTEGER_ARRAY, DOUBLE_ARRAY, STRING_ARRAY):
            return current, []
        if all(isinstance(v, bool) for v in value):
            return BOOL_ARRAY, value
        numbers = all(_is_number(v) for v in value)
        if numbers and all(isinstance(v, int) for v in value) and not floating:
            return INTEGER_ARRAY, value
        if numbers:
            return DOUBLE_ARRAY, [float(v) for v in value]
        if all(isinstance(v, str) for v in value):
            return STRING_ARRAY, value
        return STRING, text
    if isinstance(value, str):
        return STRING, value
    return STRING, text  # empty, a mapping, a date...: the text as typed


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def _as_float(value: Any) -> Any:
    """A string that reads as a number, as that number; anything else as it is."""
    if isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


def to_message(kind: int, value: Any) -> Any:
    from rcl_interfaces.msg import ParameterValue

    message = ParameterValue(type=kind)
    if kind != NOT_SET:
        setattr(message, _FIELDS[kind], value)
    return message


def to_python(message: Any) -> Any:
    """A ParameterValue's value: arrays as lists (rclpy gives ``array('d')``), NOT_SET as None."""
    if message.type == NOT_SET or message.type not in _FIELDS:
        return None
    value = getattr(message, _FIELDS[message.type])
    if message.type == BYTE_ARRAY:
        return [b[0] if isinstance(b, bytes) else int(b) for b in value]
    if message.type in (BOOL_ARRAY, INTEGER_ARRAY, DOUBLE_ARRAY, STRING_ARRAY):
        return list(value)
    return value


def describe(message: Any) -> str:
    """``ros2 param get``'s line: ``Double array value is: [60.0]``."""
    if message.type == NOT_SET:
        return "Parameter not set."
    if message.type not in _LABELS:
        raise ToolError(f"unknown parameter type {message.type}")
    return f"{_LABELS[message.type]} {to_python(message)}"


def _names(g: graph.Graph, node: str) -> list[str]:
    from rcl_interfaces.srv import ListParameters

    response = g.call(ListParameters, f"{node}/list_parameters", ListParameters.Request(), what=node)
    return sorted(response.result.names)


def _values(g: graph.Graph, node: str, names: list[str], *, strict: bool = True) -> list[Any]:
    """The ParameterValue of each name; ``ToolError`` if the node does not have one of them (``strict``; else none)."""
    from rcl_interfaces.srv import GetParameters

    response = g.call(GetParameters, f"{node}/get_parameters", GetParameters.Request(names=names), what=node)
    if strict and len(response.values) != len(names):  # rclpy answers nothing at all if one is not declared
        missing = names[0] if len(names) == 1 else "one of " + ", ".join(names)
        raise ToolError(f"{node}: parameter {missing} not set")
    return list(response.values)


@graph.command("param list", interrupted=INTERRUPTED)
def param_list(node: str) -> int:
    """``ros2 param list /node``: the node's parameter names, sorted, indented."""
    node = graph.absolute(node)
    with graph.open_graph("param list") as g:
        names = _names(g, node)
    for name in names:
        print(f"  {name}", flush=True)
    return 0


@graph.command("param get", interrupted=INTERRUPTED)
def param_get(node: str, name: str) -> int:
    """``ros2 param get /node name``: ``Double value is: 60.0`` and the like."""
    node = graph.absolute(node)
    with graph.open_graph("param get") as g:
        (value,) = _values(g, node, [name])
    print(describe(value), flush=True)
    return 0


@graph.command("param set", interrupted=INTERRUPTED)
def param_set(node: str, name: str, value_text: str) -> int:
    """``ros2 param set /node name value``: ``Set parameter successful``, or ``Setting parameter failed: <the node's
    reason>`` on stderr and exit 1."""
    from rcl_interfaces.msg import Parameter
    from rcl_interfaces.srv import SetParameters

    node = graph.absolute(node)
    with graph.open_graph("param set") as g:
        current = _values(g, node, [name], strict=False)
        current_type = current[0].type if current else NOT_SET
        if current_type == NOT_SET:  # undeclared (rclpy's own reason names none)
            close = difflib.get_close_matches(name, _names(g, node), n=3)
            hint = f" (did you mean {', '.join(close)}?)" if close else f" (`param list {node}` lists them)"
            print(f"Setting parameter failed: {node} has no parameter {name}{hint}", file=sys.stderr, flush=True)
            return 1
        kind, value = parse_value(value_text, current_type)
        request = SetParameters.Request(parameters=[Parameter(name=name, value=to_message(kind, value))])
        (result,) = g.call(SetParameters, f"{node}/set_parameters", request, what=node).results
    if result.successful:
        print("Set parameter successful" + (f": {result.reason}" if result.reason else ""), flush=True)
        return 0
    print("Setting parameter failed" + (f": {result.reason}" if result.reason else ""), file=sys.stderr, flush=True)
    return 1


@graph.command("param dump", interrupted=INTERRUPTED)
def param_dump(node: str) -> int:
    """``ros2 param dump /node``: every parameter as a ROS 2 parameter file, as ros2cli writes it."""
    import yaml

    node = graph.absolute(node)
    with graph.open_graph("param dump") as g:
        names = _names(g, node)
        values = _values(g, node, names) if names else []
    document = dump_document(node, {n: to_python(v) for n, v in zip(names, values, strict=True)})
    print(
        yaml.safe_dump(document, default_flow_style=False, allow_unicode=True, width=float("inf")), end="", flush=True
    )
    return 0


def dump_document(node: str, values: dict[str, Any]) -> dict[str, Any]:
    """``{node: {"ros__parameters": ...}}`` with ``a.b`` nested as ``a: {b: ...}``, as ros2 param dump does
    (a parameter that is not set, None, stays: ``null``)."""
    parameters: dict[str, Any] = {}
    for name, value in values.items():
        *path, leaf = name.split(".")
        where = parameters
        for part in path:
            if not isinstance(where.setdefault(part, {}), dict):  # `a` and `a.b` both set: keep `a.b` flat
                where, leaf = parameters, name
                break
            where = where[part]
        where[leaf] = value
    return {node: {"ros__parameters": parameters}}
