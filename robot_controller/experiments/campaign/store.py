"""A campaign's results on disk: ``DIR/results.parquet``, one row per finished run, and ``DIR/campaign.json``, what
campaign the folder holds, so that the same command resumes it and another is refused.

Runs that finish are written at once as a small part file (``DIR/parts/``); the table is rewritten from the parts
every few seconds and at the end. Every file is written to a temporary name, then renamed: a campaign killed at any
instant leaves whole files, and the next start folds the parts in (each run once) and runs only the missing ones."""

from __future__ import annotations

import json
import os
import time
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq

from robot_controller.core.errors import ConfigError
from robot_controller.experiments.campaign.fingerprint import changed, combined

RESULTS = "results.parquet"
CAMPAIGN = "campaign.json"
PARTS = "parts"
#: How often the whole table is rewritten while runs finish, s (each run is safe in its part file meanwhile).
COMPACT_EVERY_S = 2.0


class ResultStore:
    """The rows of ``folder``'s campaign: those already there (a resume) and those added as runs finish."""

    def __init__(self, folder: Path, parts: dict[str, str], about: dict[str, Any]) -> None:
        """Open ``folder`` for the campaign whose fingerprint has these ``parts`` (:func:`fingerprint.parts`;
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
