"""A campaign's results on disk: ``DIR/results.parquet``, one row per finished run, and ``DIR/campaign.json``, what
campaign the folder holds, part by part (:func:`parts`): the spec's runs (robot, duration, runs, seed, draws, the
controllers), the contents of every file it names (the config file, each law's file, the robot's URDF), and the code
that runs them (robot_controller's version and a hash of its source and data, MuJoCo's version). The same command
resumes it; a part that differs refuses it, naming that part.

Runs that finish are written at once as a small part file (``DIR/parts/``); the table is rewritten from the parts
every few seconds and at the end. Every file is written to a temporary name, then renamed: a campaign killed at any
instant leaves whole files, and the next start folds the parts in (each run once) and runs only the missing ones."""

from __future__ import annotations

import hashlib
import inspect
import json
import os
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from robot_controller import resources
from robot_controller.core.errors import ConfigError
from robot_controller.experiments.campaign.spec import CampaignSpec

RESULTS = "results.parquet"
CAMPAIGN = "campaign.json"
PARTS = "parts"
#: How often the whole table is rewritten while runs finish, s (each run is safe in its part file meanwhile).
COMPACT_EVERY_S = 2.0
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


class ResultStore:
    """The rows of ``folder``'s campaign: those already there (a resume) and those added as runs finish."""

    def __init__(self, folder: Path, parts: dict[str, str], about: dict[str, Any]) -> None:
        """Open ``folder`` for the campaign whose fingerprint has these ``parts`` (:func:`parts`;
        ``about``: what else ``campaign.json`` says of it).

        :raises ConfigError: the folder holds another campaign's results, in one line naming what differs
        """
        self.folder = folder
        self.path = folder / RESULTS
        self.parts = folder / PARTS
        for stale in [*folder.glob(".*.tmp"), *self.parts.glob(".*.tmp")]:  # a write a kill cut: the files stand
            stale.unlink(missing_ok=True)
        marker = folder / CAMPAIGN
        fingerprint = combined(parts)
        if marker.is_file():
            held = json.loads(marker.read_text())
            if held.get("fingerprint") != fingerprint:
                differs = changed(held["parts"], parts) if isinstance(held.get("parts"), dict) else []
                why = "; ".join(differs) or "an earlier robot_controller's campaign, which kept no record of its parts"
                raise ConfigError(
                    f"--out {folder}: holds another campaign's results, not resumed: {why}; "
                    "choose another directory, or put back what changed"
                )
        elif self.path.exists():
            raise ConfigError(f"--out {folder}: holds a {RESULTS} of no campaign; choose another directory")
        else:
            record = {"fingerprint": fingerprint, "parts": parts, **about}
            _atomic_write(marker, json.dumps(record, indent=2).encode())
        self.rows: list[dict[str, Any]] = []
        seen: set[tuple[str, int]] = set()
        files = [self.path] if self.path.exists() else []
        for path in files + sorted(self.parts.glob("*.parquet")):
            for row in read_rows(path):
                if _key(row) not in seen:  # a part folded into the table before the kill: once
                    seen.add(_key(row))
                    self.rows.append(row)
        self._compacted_at = -float("inf")
        self._parts_written = 0
        self.parts.mkdir(exist_ok=True)
        if self.rows:
            self.compact()

    def done(self) -> set[tuple[str, int]]:
        """``(controller, run_id)`` of every run already in the table."""
        return {_key(row) for row in self.rows}

    def add(self, rows: Iterable[dict[str, Any]]) -> None:
        """Add ``rows``: written at once as a part file, folded into the table within :data:`COMPACT_EVERY_S`."""
        added = list(rows)
        if not added:
            return
        self.rows.extend(added)
        first = added[0]
        name = f"{first['controller'] or 'run'}-{int(first['run_id']):06d}-{os.getpid()}-{self._parts_written}"
        self._parts_written += 1
        write_rows(added, self.parts / f"{name}.parquet")
        if time.monotonic() - self._compacted_at >= COMPACT_EVERY_S:
            self.compact()

    def compact(self) -> None:
        """Write the whole table, then drop the parts it holds (a kill between the two: the next start dedups)."""
        held = sorted(self.parts.glob("*.parquet"))
        self.rows.sort(key=_key)
        write_rows(self.rows, self.path)
        for part in held:
            part.unlink(missing_ok=True)
        self._compacted_at = time.monotonic()


def _key(row: dict[str, Any]) -> tuple[str, int]:
    return row["controller"], int(row["run_id"])


def read_rows(path: Path) -> list[dict[str, Any]]:
    return pq.read_table(path).to_pylist()


def write_rows(rows: list[dict[str, Any]], path: Path) -> None:
    """``rows`` as a Parquet table at ``path``; columns in first-seen order, a row without one holds null."""
    names: dict[str, None] = {}
    for row in rows:
        names.update(dict.fromkeys(row))
    columns = {name: [row.get(name) for row in rows] for name in names}
    table = pa.table({name: pa.array(values) for name, values in columns.items()})
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    _atomic_write(path, sink.getvalue().to_pybytes())


def _atomic_write(path: Path, data: bytes) -> None:
    tmp = path.parent / f".{path.name}.{os.getpid()}.tmp"
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)
