"""One parameter's definition and the check of a value against it; ``per_joint``, the one way a per-joint value (a
number for all joints, or one per joint) becomes an array."""

from __future__ import annotations

import array
import copy
import difflib
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from robot_controller.core.errors import ConfigError


@dataclass(frozen=True)
class ParamSpec:
    """One parameter of a node.

    :param kind: ``bool``, ``int``, ``float`` or ``str``; a float may be a list, ``per_joint`` (one
        number for every joint, or one per joint of the URDF) or of ``length`` numbers
    :param allow_empty: a list may be empty, "not set" (``None`` too: rcl reads a file's ``[]`` so)
    :param safety: a timeout or limit that protects the arm: read-only, so only the run's configuration sets it
    """

    name: str
    kind: type
    default: Any
    description: str
    minimum: float | None = None
    exclusive_minimum: bool = False
    maximum: float | None = None
    choices: tuple[str, ...] | None = None
    read_only: bool = False
    per_joint: bool = False
    length: int | None = None
    allow_empty: bool = False
    safety: bool = False

    def __post_init__(self) -> None:
        assert self.read_only or not self.safety, f"{self.name}: a safety setting is read-only"
        self.validate(self.default)  # a default that fails its own rules is a bug here, found at import

    @property
    def refusal(self) -> str:
        """Why a node refuses to change this parameter at run time (it is read-only)."""
        if self.safety:
            return "safety setting: set it in the run's config, not at run time"
        return "read-only: fixed when the node starts; set it in the run's config"

    @property
    def is_list(self) -> bool:
        return self.per_joint or self.length is not None

    def default_value(self) -> Any:
        return copy.copy(self.default)

    def value_rules(self, markdown: bool = False) -> list[str]:
        """The range and the choices a value must keep to, as text (``markdown``: ≥, ≤ and quoted choices)."""
        at_least, at_most = ("≥", "≤") if markdown else (">=", "<=")
        rules = []
        if self.minimum is not None:
            rules.append(f"{'>' if self.exclusive_minimum else at_least} {self.minimum:g}")
        if self.maximum is not None:
            rules.append(f"{at_most} {self.maximum:g}")
        if self.choices:
            rules.append(", ".join(f"`{c}`" for c in self.choices) if markdown else "one of " + ", ".join(self.choices))
        return rules

    def describe(self) -> str:
        rules = self.value_rules()
        if self.per_joint:
            rules.append("per joint: one value, or one per joint")
        if self.length is not None:
            rules.append(f"{self.length} values")
        if self.allow_empty:
            rules.append("or empty")
        return self.description + (f" [{'; '.join(rules)}]" if rules else "")

    def validate(self, value: Any) -> Any:
        """The value normalised (floats as float, lists as list of float); ``ConfigError`` if it is not accepted."""
        kind = self.kind
        if kind is bool:
            if not isinstance(value, bool):
                raise ConfigError(f"{self.name}: expected true or false, got {value!r}")
            return value
        if kind is str:
            if not isinstance(value, str):
                raise ConfigError(f"{self.name}: expected a string, got {value!r}")
            if self.choices and value not in self.choices:
                hint = difflib.get_close_matches(value, self.choices, n=1)
                raise ConfigError(
                    f"{self.name}: {value!r} is not one of {list(self.choices)}"
                    + (f" (did you mean {hint[0]!r}?)" if hint else "")
                )
            return value
        if kind is int:
            if isinstance(value, bool) or not isinstance(value, int):
                raise ConfigError(f"{self.name}: expected an integer, got {value!r}")
            self._check_range(value)
            return value
        if kind is float:
            if value is None and self.allow_empty:  # what rclpy makes of a parameter file's []
                return []
            if not self.is_list:
                return self._number(value)
            if isinstance(value, (list, tuple, array.array, np.ndarray)):  # rclpy gives array('d')
                if len(value) == 0 and self.allow_empty:
                    return []
                if len(value) == 0:
                    raise ConfigError(f"{self.name}: expected a number or a non-empty list of numbers")
                if self.length is not None and len(value) != self.length:
                    raise ConfigError(f"{self.name}: expected {self.length} values, got {len(value)}")
                return [self._number(v) for v in value]
            if self.length is not None:
                raise ConfigError(f"{self.name}: expected a list of {self.length} numbers, got {value!r}")
            return self._number(value)
        raise AssertionError(kind)

    def _number(self, value: Any) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{self.name}: expected a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            raise ConfigError(f"{self.name}: must be finite, got {value}")
        self._check_range(value)
        return value

    def _check_range(self, value: float) -> None:
        if self.minimum is not None and (value < self.minimum or (self.exclusive_minimum and value == self.minimum)):
            raise ConfigError(
                f"{self.name}: must be {'>' if self.exclusive_minimum else '>='} {self.minimum:g}, got {value:g}"
            )
        if self.maximum is not None and value > self.maximum:
            bound = " (a safety setting's bound)" if self.safety else ""
            raise ConfigError(f"{self.name}: must be <= {self.maximum:g}{bound}, got {value:g}")


def per_joint(name: str, value: float | list[float], joint_count: int) -> np.ndarray:
    """A per-joint value as one number per joint: a single number applies to every joint."""
    values = np.atleast_1d(np.asarray(value, dtype=float))
    if values.size == 1:
        return np.full(joint_count, float(values[0]))
    if values.size != joint_count:
        expected = "1 value" if joint_count == 1 else f"1 or {joint_count} values (one per joint)"
        raise ConfigError(f"{name}: expected {expected}, got {values.size}")
    return values
