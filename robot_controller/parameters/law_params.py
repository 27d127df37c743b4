"""A law's declared parameters as ``pid_controller`` node parameters ``law.NAME``: which exist depends on
``controller_type``, so they are not in the schema; each is checked by the law's own rules
(:mod:`robot_controller.core.laws.law_parameters`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from robot_controller.core.laws import Parameter, law_parameters, registry
from robot_controller.parameters.spec import ParamSpec


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


def law_specs(controller_type: str) -> tuple[LawParamSpec, ...]:
    """The ``law.*`` parameters of the law ``controller_type`` names (none for a built-in law; ``ConfigError`` if it
    names no law)."""
    if registry.is_builtin(controller_type):
        return ()
    law_class = registry.resolve(controller_type)
    specs = []
    for parameter in law_parameters.declared(law_class):
        default = law_parameters.check(parameter, parameter.default)  # numbers as float: a double in ROS
        kind = bool if isinstance(default, bool) else str if isinstance(default, str) else float
        spec = LawParamSpec(
            law_parameters.PREFIX + parameter.name,
            kind,
            default,
            parameter.description,
            minimum=parameter.minimum,
            maximum=parameter.maximum,
            per_joint=parameter.per_joint,
            parameter=parameter,
            law=law_class.__name__,
        )
        specs.append(spec)
    return tuple(specs)


def node_specs(node: str, values: dict[str, Any]) -> tuple[ParamSpec, ...]:
    """Every parameter of ``node`` with these values: the schema's, and for the controller its law's."""
    from robot_controller.parameters.schema import SCHEMA

    if node != law_parameters.NODE or "controller_type" not in values:
        return SCHEMA[node]
    return (*SCHEMA[node], *law_specs(values["controller_type"]))
