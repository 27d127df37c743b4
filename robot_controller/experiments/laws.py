"""``--controller SPEC`` for the experiments: the law as pid_controller's ``controller_type`` names it,
resolved at once (a bad spec is one ``ConfigError`` line before anything runs), a file's path made absolute."""

from __future__ import annotations

from pathlib import Path

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError
from robot_controller.core.laws import registry


def controller_type(spec: object, base: Path | None = None, where: str = "--controller") -> str:
    """``spec`` checked (its class loads) and as the nodes get it: a file's path absolute from ``base`` (default the
    current directory).

    :raises ConfigError: ``where``, then why
    """
    if not isinstance(spec, str) or not spec.strip():
        raise ConfigError(f"{where}: expected pid, lqr, an installed law or path/to/file.py:Class, got {spec!r}")
    spec = registry.with_absolute_path(spec.strip(), base)
    try:
        registry.resolve(spec)
    except ConfigError as exc:
        raise ConfigError(f"{where}: " + str(exc).removeprefix("controller_type: ")) from None
    return spec


def with_controller(params: cfg.Params, spec: str | None) -> cfg.Params:
    """``params`` with pid_controller's ``controller_type`` set to ``spec`` (unchanged for None)."""
    if spec is None:
        return params
    return cfg.merge(params, {"pid_controller": {"controller_type": controller_type(spec)}})


def is_law(name: str) -> bool:
    """Whether ``name`` is a law (``module:Class``, ``file.py:Class``, an installed law), not a configuration."""
    return ":" in name or name in registry.installed_laws()


def label(spec: str) -> str:
    """A short name for ``spec``: the class name of ``…:Class``, else the spec."""
    return spec.strip().rpartition(":")[2]
