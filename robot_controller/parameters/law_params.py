"""A plugin law's declared parameters as ``pid_controller`` parameters ``law.NAME``.

Which ``law.*`` keys exist depends on ``controller_type``, so they are not in
the schema: :func:`law_specs` makes one :class:`LawParamSpec` per declared
:class:`~robot_controller.core.laws.Parameter`, checked by the law's own rules
(:mod:`robot_controller.core.laws.parameters`). The nodes declare them, the
parameter files and the whole-configuration check accept them, ``params``
lists them. :func:`settle` is what :func:`~robot_controller.parameters.files.load_stack`
does with them: ``controller_type`` made absolute if it names a file, every
``law.*`` value given checked against the law (naming the file it came from),
and the law's defaults filled in for the rest. No rclpy here.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from robot_controller.core.errors import ConfigError
from robot_controller.core.laws import parameters as law_parameters
from robot_controller.core.laws import registry
from robot_controller.core.laws.interface import Parameter
from robot_controller.parameters.spec import ParamSpec

PREFIX = law_parameters.PREFIX  # "law."
NODE = "pid_controller"  # the only node with a control law


@dataclass(frozen=True)
class LawParamSpec(ParamSpec):
    """A law's declared parameter as a node parameter: checked by the law's rules."""

    parameter: Parameter | None = None
    law: str = ""  #: the law's class name, for the listing

    def validate(self, value: Any) -> Any:
        if self.parameter is None:  # the base class's own check at construction, before the field is set
            return value
        return law_parameters.check(self.parameter, value)

    def describe(self) -> str:
        default = self.default if not isinstance(self.default, list) else "[" + ", ".join(map(str, self.default)) + "]"
        return f"{super().describe()} (the law {self.law}'s; default {default!s})"


def is_law_key(name: str) -> bool:
    return name.startswith(PREFIX)


def plain_value(name: str, value: Any) -> Any:
    """What a parameter file may give a ``law.*`` key before the law is known: a number, a
    bool, a string or a list of numbers (checked against the law's declaration later)."""
    if isinstance(value, (bool, int, float, str)):
        return value
    if isinstance(value, (list, tuple)) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value):
        return list(value)
    raise ConfigError(f"{name}: expected a number, true or false, a string or a list of numbers, got {value!r}")


def _spec(law_class: type, parameter: Parameter) -> LawParamSpec:
    default = law_parameters.check(parameter, parameter.default)  # numbers as float: a double parameter in ROS
    kind = bool if isinstance(default, bool) else str if isinstance(default, str) else float
    return LawParamSpec(
        PREFIX + parameter.name,
        kind,
        default,
        parameter.description,
        minimum=parameter.minimum,
        maximum=parameter.maximum,
        per_joint=parameter.per_joint,
        parameter=parameter,
        law=law_class.__name__,
    )


def law_specs(controller_type: str) -> tuple[LawParamSpec, ...]:
    """The ``law.*`` parameters of the law ``controller_type`` names (none for a built-in law);
    ``ConfigError`` naming ``controller_type`` if it names no law."""
    if registry.is_builtin(controller_type):
        return ()
    law_class = registry.resolve(controller_type)
    return tuple(_spec(law_class, parameter) for parameter in law_parameters.declared(law_class))


def node_specs(node: str, values: dict[str, Any]) -> tuple[ParamSpec, ...]:
    """Every parameter of ``node`` with these values: the schema's, and for the controller its law's."""
    from robot_controller.parameters.schema import SCHEMA

    if node != NODE or "controller_type" not in values:
        return SCHEMA[node]
    return (*SCHEMA[node], *law_specs(values["controller_type"]))


def check_values(values: dict[str, Any], where: str = NODE) -> None:
    """The ``law.*`` values of a controller's parameters against the law ``controller_type`` names:
    one it does not declare, or a value its declaration refuses, is a ``ConfigError`` naming ``where``."""
    given = [name for name in values if is_law_key(name)]
    try:
        specs = {spec.name: spec for spec in law_specs(values["controller_type"])}
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None
    for name in given:
        spec = specs.get(name)
        if spec is None:
            raise ConfigError(f"{where}.{_unknown(name, values['controller_type'], specs)}")
        try:
            spec.validate(values[name])
        except ConfigError as exc:
            raise ConfigError(f"{where}.{exc}") from None


def _unknown(name: str, controller_type: str, specs: dict[str, LawParamSpec]) -> str:
    if not specs and registry.is_builtin(controller_type):
        return f"{name}: controller_type {controller_type} is built in and takes no law.* parameters"
    law = registry.resolve(controller_type).__name__
    hint = difflib.get_close_matches(name, list(specs), n=1)
    declared = ", ".join(sorted(specs)) or "none"
    return f"{name}: the law {law} declares no such parameter" + (
        f" (did you mean {hint[0]!r}?)" if hint else f" (it declares {declared})"
    )


def settle(params: dict[str, dict[str, Any]], sources: list[tuple[Path, dict[str, dict[str, Any]]]] = ()) -> None:
    """In place, on a whole stack's parameters: the controller's ``controller_type`` made absolute
    if it names a file; each ``law.*`` value in ``sources`` (a file and what it gave) checked against
    the law, naming that file; then the law's defaults for every ``law.*`` not given.

    :raises ConfigError: one line naming the file (if any), the key and the problem
    """
    ctrl = params.get(NODE)
    if ctrl is None or "controller_type" not in ctrl:
        return
    ctrl["controller_type"] = registry.with_absolute_path(ctrl["controller_type"])
    for path, layer in sources:
        given = {k: v for k, v in layer.get(NODE, {}).items() if is_law_key(k)}
        if given:
            check_values({"controller_type": ctrl["controller_type"], **given}, where=f"{path}: {NODE}")
    check_values(ctrl)
    for spec in law_specs(ctrl["controller_type"]):
        ctrl.setdefault(spec.name, spec.default_value())
