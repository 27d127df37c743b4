"""A plugin law's parameter values: its declared defaults with the values
given over them, each checked against its declaration (type, range, one per
joint). Every refusal names the parameter as ROS knows it, ``law.NAME``."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from robot_controller.core.errors import ConfigError
from robot_controller.core.laws.interface import Parameter

PREFIX = "law."


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
