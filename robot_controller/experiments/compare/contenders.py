"""``compare``'s contenders: named configurations (:data:`CONTENDERS`, and ``default``: the default
preset as it is) or laws (``module:Class``, ``file.py:Class`` or an installed law's name, with the
default stack). A configuration's name wins over an installed law's (``pid``, ``lqr``)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

from robot_controller.core.errors import ConfigError
from robot_controller.experiments import laws


@dataclass(frozen=True)
class Contender:
    name: str
    description: str
    preset: str
    overrides: dict[str, Any]
    robot: str = "one_dof"


def _stack(controller_type: str, feedforward: str, estimator: str) -> dict[str, str]:
    return {"controller_type": controller_type, "feedforward": feedforward, "estimator": estimator}


CONTENDERS = (
    Contender("tutorial", "the tutorial's controller as written", "tutorial", {}),
    Contender("pid", "PID, derivative on velocity error", "default", _stack("pid", "none", "none")),
    Contender("pid_ff", "PID + model feedforward", "default", _stack("pid", "full", "none")),
    Contender("pid_ff_kf", "PID + feedforward + Kalman filter", "default", _stack("pid", "full", "kalman")),
    Contender("lqr", "LQR + feedforward + Kalman filter (default)", "default", _stack("lqr", "full", "kalman")),
)
#: Configurations by name for ``--controllers``: the contenders, and the default preset as it is.
NAMED = {c.name: c for c in CONTENDERS} | {"default": Contender("default", "the default preset", "default", {})}


def contenders(names: Sequence[str] | None = None) -> tuple[Contender, ...]:
    """The contenders ``names`` (``--controllers``) name, in order; every contender for None.

    :raises ConfigError: a name that is neither a configuration nor a law
    """
    if names is None:
        return CONTENDERS
    chosen: list[Contender] = []
    for name in (n.strip() for n in names):
        if name in NAMED:
            contender = NAMED[name]
        elif laws.is_law(name):
            spec = laws.controller_type(name)
            contender = Contender(
                laws.label(name), f"{name} with the default stack", "default", {"controller_type": spec}
            )
        else:
            raise ConfigError(
                f"--controllers: {name!r} is neither a configuration ({', '.join(NAMED)}) nor a law "
                "(module:Class, path/to/file.py:Class or an installed law's name)"
            )
        taken = {c.name for c in chosen}
        if contender.name in taken:  # two laws of the same class name: number the second
            contender = replace(
                contender,
                name=next(f"{contender.name}_{k}" for k in range(2, 99) if f"{contender.name}_{k}" not in taken),
            )
        chosen.append(contender)
    if not chosen:
        raise ConfigError("--controllers: name at least one")
    return tuple(chosen)
