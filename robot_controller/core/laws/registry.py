"""Finding a law by the name ``controller_type`` gives: an installed plugin's
name (the ``robot_controller.laws`` entry-point group, where the built-in
``pid`` and ``lqr`` are registered too), ``package.module:Class``, or
``path/to/file.py:Class``. Every failure is one line naming the spec."""

from __future__ import annotations

import hashlib
import importlib
import importlib.metadata
import importlib.util
import sys
from functools import lru_cache
from pathlib import Path

from robot_controller.core.errors import ConfigError

ENTRY_POINT_GROUP = "robot_controller.laws"
BUILTIN_LAWS = ("pid", "lqr")


def installed_laws() -> dict[str, importlib.metadata.EntryPoint]:
    """The laws installed under the entry-point group, by name."""
    return {ep.name: ep for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)}


def is_builtin(spec: str) -> bool:
    return spec in BUILTIN_LAWS


@lru_cache(maxsize=32)
def resolve(spec: str) -> type:
    """The law class ``spec`` names (loaded once per process); ``ConfigError`` if it names none."""
    spec = spec.strip()
    if not spec:
        raise ConfigError("controller_type: empty; give pid, lqr, an installed law, module:Class or file.py:Class")
    if ":" not in spec:
        laws = installed_laws()
        if spec not in laws:
            known = ", ".join(sorted(laws)) or "none (is robot_controller installed?)"
            raise ConfigError(
                f"controller_type: {spec!r} is not an installed law (installed: {known}); "
                "a law of your own is named module:Class or path/to/file.py:Class"
            )
        return _checked(spec, _load(spec, laws[spec].load))
    where, _, class_name = spec.rpartition(":")
    if not class_name.isidentifier():
        raise ConfigError(f"controller_type: {spec!r}: {class_name!r} after the ':' is not a class name")
    if _names_a_file(where):
        module = _load(spec, lambda: _import_file(Path(where).expanduser()))
    else:
        module = _load(spec, lambda: importlib.import_module(where))
    law = getattr(module, class_name, None)
    if law is None:
        raise ConfigError(f"controller_type: {spec!r}: {where} has no {class_name!r}")
    return _checked(spec, law)


def _names_a_file(where: str) -> bool:
    """Whether the part before a spec's ':' is a file's path (else a module's dotted name)."""
    return where.endswith(".py") or "/" in where


def with_absolute_path(spec: str, base: Path | None = None) -> str:
    """``path/to/file.py:Class`` with the path made absolute (from ``base``, default the current
    directory), so that a process started elsewhere finds the same file; any other spec as it is."""
    if not isinstance(spec, str) or ":" not in spec:
        return spec
    where, _, class_name = spec.strip().rpartition(":")
    if not _names_a_file(where):
        return spec
    path = Path(where).expanduser()
    if not path.is_absolute():
        path = (base or Path.cwd()) / path
    return f"{path.resolve()}:{class_name}"


def _load(spec: str, load):
    try:
        return load()
    except ConfigError:
        raise
    except Exception as exc:  # the user's code failed to import: say how, in one line
        raise ConfigError(f"controller_type: {spec!r} failed to load: {type(exc).__name__}: {exc}") from exc


def _import_file(path: Path):
    if not path.is_file():
        raise ConfigError(f"controller_type: no such file {str(path)!r} (relative to {Path.cwd()})")
    path = path.resolve()
    # One module per file, named after its path, so two laws in files of the same name do not collide.
    name = f"robot_controller_law_{path.stem}_{hashlib.sha1(str(path).encode()).hexdigest()[:8]}"
    module_spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(module_spec)
    sys.modules[name] = module  # dataclasses and pickling look a class's module up here
    try:
        module_spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module


def _checked(spec: str, law: object) -> type:
    if not isinstance(law, type) or not callable(getattr(law, "update", None)):
        raise ConfigError(f"controller_type: {spec!r} is not a class with an update() method")
    return law
