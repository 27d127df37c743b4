"""What makes two campaigns the same one, part by part: the spec's runs (robot, duration, runs, seed, draws, the
controllers), the contents of every file it names (the config file, each law's file, the robot's URDF), and the code
that runs them (robot_controller's version and a hash of its source and data, MuJoCo's version). A resume must
continue its own campaign: a part that differs refuses it, naming that part."""

from __future__ import annotations

import hashlib
import inspect
import json
from pathlib import Path

from robot_controller import resources
from robot_controller.experiments.campaign.spec import CampaignSpec

SPEC = "the spec's runs (robot, duration_s, runs, seed, vary or controllers)"
CODE = "robot_controller"
#: The folders beside the package whose files are its data (presets, robot descriptions).
DATA_FOLDERS = ("config", "description")


def parts(spec: CampaignSpec, controllers: tuple[str, ...]) -> dict[str, str]:
    """``{what: its hash or version}``: the campaign's spec, each file it names, the code; ``controllers`` are the
    compared laws as ``controller_type`` names them (``""``: the spec's or its config's)."""
    body = {
        "robot": spec.robot,
        "config": str(spec.config) if spec.config else None,
        "duration_s": spec.duration_s,
        "runs": spec.runs,
        "seed": spec.seed,
        "vary": [[v.key, v.kind, list(v.args), v.per_joint] for v in spec.vary],
        "controllers": list(controllers),
    }
    out = {SPEC: _digest(json.dumps(body, sort_keys=True))}
    files: list[tuple[str, Path]] = []
    if spec.config is not None:
        files.append(("the config file", spec.config))
    for controller in controllers or ("",):
        params = spec.base_params(controller or None)
        law_file = _law_file(params["pid_controller"]["controller_type"])
        if law_file is not None:
            files.append(("the law file", law_file))
        files.append(("the URDF", resources.resolve_urdf(params["simulator"]["urdf_path"]).resolve()))
    for what, path in files:
        out[f"{what} {path}"] = _file_digest(path)
    out[CODE] = code_version()
    return out


def combined(held: dict[str, str]) -> str:
    """One hash of every part."""
    return _digest(json.dumps(held, sort_keys=True))[:16]


def changed(held: dict[str, str], now: dict[str, str]) -> list[str]:
    """What differs between the parts a folder holds and this campaign's, each named (the code: then and now)."""
    out = []
    for what in [*now, *(w for w in held if w not in now)]:
        then, current = held.get(what), now.get(what)
        if then == current:
            continue
        if then is None or current is None:
            out.append(f"{what} ({'not named then' if then is None else 'not named now'})")
        elif what == SPEC:
            out.append(f"{what} changed")
        elif what == CODE:
            out.append(f"{what}: {then} then, {current} now")
        else:
            out.append(f"{what}: its contents changed")
    return out


def code_version() -> str:
    """robot_controller's version, a hash of its Python source and data files, and MuJoCo's version."""
    import mujoco

    import robot_controller

    package = Path(robot_controller.__file__).resolve().parent
    files = [(package, p) for p in sorted(package.rglob("*.py"))]
    try:
        share = resources.share_dir()
    except FileNotFoundError:
        share = None
    if share is not None:
        files += [(share, p) for folder in DATA_FOLDERS for p in sorted((share / folder).rglob("*")) if p.is_file()]
    h = hashlib.sha256()
    for base, path in files:  # the paths relative to where they sit: the same code checked out elsewhere is the same
        h.update(path.relative_to(base).as_posix().encode())
        h.update(path.read_bytes())
    return f"{robot_controller.__version__} (source {h.hexdigest()[:12]}, mujoco {mujoco.__version__})"


def _law_file(controller_type: str) -> Path | None:
    """The file defining a law of one's own (None: a built-in law, or one in robot_controller: its hash covers it)."""
    import robot_controller
    from robot_controller.core.laws import registry

    if registry.is_builtin(controller_type):
        return None
    try:
        source = inspect.getsourcefile(registry.resolve(controller_type))
    except TypeError:
        return None
    if source is None:
        return None
    path = Path(source).resolve()
    return None if path.is_relative_to(Path(robot_controller.__file__).resolve().parent) else path


def _file_digest(path: Path) -> str:
    try:
        return _digest(path.read_bytes())
    except OSError:
        return "missing"


def _digest(data: str | bytes) -> str:
    return hashlib.sha256(data.encode() if isinstance(data, str) else data).hexdigest()[:16]
