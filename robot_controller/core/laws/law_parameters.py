"""A law's declared parameters as ``pid_controller``'s ``law.NAME``: each value checked against its declaration
(type, range, one per joint), a law's values (its defaults with the values given over them), and what a stack's
parameter files may give. Every refusal names ``law.NAME``. Their node parameter specs: ``parameters.law_params``."""

from __future__ import annotations

import difflib
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

import robot_controller.core.laws.registry as registry
from robot_controller.core.errors import ConfigError
from robot_controller.core.laws.interface import Parameter

PREFIX = "law."
NODE = "pid_controller"  #: the only node with a control law


def declared(law_class: type) -> tuple[Parameter, ...]:
    """The parameters ``law_class`` declares (none if it declares nothing), checked for sense."""
    parameters = tuple(getattr(law_class, "parameters", ()) or ())
    names = [p.name for p in parameters if isinstance(p, Parameter)]
    if len(names) != len(parameters):
        raise ConfigError(f"{law_class.__name__}.parameters: every entry must be a robot_controller Parameter")
    if len(set(names)) != len(names):
        raise ConfigError(f"{law_class.__name__}.parameters: a name is declared twice in {names}")
    for parameter in parameters:
        if not parameter.name.replace("_", "a").isalnum():
            raise ConfigError(f"{law_class.__name__}.parameters: {parameter.name!r} is not a plain name")
        check(parameter, parameter.default)  # a default that breaks its own range is the law's bug
    return parameters


def declared_by(controller_type: str) -> dict[str, Parameter]:
    """The parameters of the law ``controller_type`` names by ``law.NAME`` (none for a built-in law);
    ``ConfigError`` naming ``controller_type`` if it names no law."""
    if registry.is_builtin(controller_type):
        return {}
    return {PREFIX + p.name: p for p in declared(registry.resolve(controller_type))}


def values(law_class: type, given: Mapping[str, Any], joint_count: int) -> dict[str, Any]:
    """Each declared parameter's value (``given`` over the defaults), per-joint ones as arrays."""
    parameters = declared(law_class)
    known = {p.name for p in parameters}
    for name in given:
        if name not in known:
            listed = ", ".join(sorted(known)) or "none"
            raise ConfigError(f"{PREFIX}{name}: {law_class.__name__} declares no such parameter (it declares {listed})")
    out = {}
    for parameter in parameters:
        value = check(parameter, given.get(parameter.name, parameter.default))
        if parameter.per_joint:
            value = per_joint(parameter, value, joint_count)
        out[parameter.name] = value
    return out


def check(parameter: Parameter, value: Any) -> Any:
    """``value`` normalised for ``parameter`` (numbers as float), or ``ConfigError``."""
    name, default = PREFIX + parameter.name, parameter.default
    if isinstance(default, bool):
        if not isinstance(value, bool):
            raise ConfigError(f"{name}: expected true or false, got {value!r}")
        return value
    if isinstance(default, str):
        if not isinstance(value, str):
            raise ConfigError(f"{name}: expected a string, got {value!r}")
        return value
    if isinstance(value, (list, tuple, np.ndarray)) or (hasattr(value, "typecode") and hasattr(value, "tolist")):
        if not parameter.per_joint and not isinstance(default, (list, tuple)):
            raise ConfigError(f"{name}: expected one number, got {list(value)!r}")
        numbers = [_number(name, parameter, v) for v in list(value)]
        if not numbers:
            raise ConfigError(f"{name}: expected a number or a non-empty list of numbers")
        return numbers
    return _number(name, parameter, value)


def _number(name: str, parameter: Parameter, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ConfigError(f"{name}: expected a number, got {value!r}")
    value = float(value)
    if not math.isfinite(value):
        raise ConfigError(f"{name}: must be finite, got {value}")
    if parameter.minimum is not None and value < parameter.minimum:
        raise ConfigError(f"{name}: must be >= {parameter.minimum:g}, got {value:g}")
    if parameter.maximum is not None and value > parameter.maximum:
        raise ConfigError(f"{name}: must be <= {parameter.maximum:g}, got {value:g}")
    return value


def per_joint(parameter: Parameter, value: float | list[float], joint_count: int) -> np.ndarray:
    numbers = np.atleast_1d(np.asarray(value, dtype=float))
    if numbers.size == 1:
        return np.full(joint_count, float(numbers[0]))
    if numbers.size != joint_count:
        raise ConfigError(f"{PREFIX}{parameter.name}: expected 1 value or {joint_count} (one per joint)")
    return numbers


def is_law_key(name: str) -> bool:
    return name.startswith(PREFIX)


def plain_value(name: str, value: Any) -> Any:
    """What a parameter file may give a ``law.*`` key before the law is known (checked against the law later)."""
    if isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (list, tuple)) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        return list(value)
    raise ConfigError(f"{name}: expected a number, true or false, a string or a list of numbers, got {value!r}")


def check_values(values: dict[str, Any], where: str = NODE) -> None:
    """The ``law.*`` values of a controller's parameters against the law ``controller_type`` names (a
    ``ConfigError`` naming ``where``)."""
    try:
        parameters = declared_by(values["controller_type"])
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None
    for name in filter(is_law_key, values):
        if name not in parameters:
            raise ConfigError(f"{where}.{_unknown(name, values['controller_type'], parameters)}")
        try:
            check(parameters[name], values[name])
        except ConfigError as exc:
            raise ConfigError(f"{where}.{exc}") from None


def _unknown(name: str, controller_type: str, parameters: dict[str, Parameter]) -> str:
    if not parameters and registry.is_builtin(controller_type):
        return f"{name}: controller_type {controller_type} is built in and takes no law.* parameters"
    law = registry.resolve(controller_type).__name__
    hint = difflib.get_close_matches(name, list(parameters), n=1)
    listed = ", ".join(sorted(parameters)) or "none"
    return f"{name}: the law {law} declares no such parameter" + (
        f" (did you mean {hint[0]!r}?)" if hint else f" (it declares {listed})"
    )


def settle(params: dict[str, dict[str, Any]], sources: list[tuple[Path, dict[str, dict[str, Any]]]] = ()) -> None:
    """In place, on a whole stack's parameters: ``controller_type`` made absolute if it names a file; each ``law.*``
    value in ``sources`` (a file and what it gave) checked against the law, naming that file; then the law's
    defaults for every ``law.*`` not given."""
    ctrl = params.get(NODE)
    if ctrl is None or "controller_type" not in ctrl:
        return
    ctrl["controller_type"] = registry.with_absolute_path(ctrl["controller_type"])
    for path, layer in sources:
        given = {k: v for k, v in layer.get(NODE, {}).items() if is_law_key(k)}
        if given:
            check_values({"controller_type": ctrl["controller_type"], **given}, where=f"{path}: {NODE}")
    check_values(ctrl)
    for name, parameter in declared_by(ctrl["controller_type"]).items():
        ctrl.setdefault(name, check(parameter, parameter.default))
