"""A campaign, run: every (controller, run) pair the folder does not hold yet, on local workers or a Ray cluster, each
row stored as it finishes, with a progress line (runs/s, time left); then the report. And one run of it again, alone,
through the full ROS graph (``campaign replay``): the campaign's stack, the run's draws, its noise seed and the
controller, as a parameter file the run loads; then its figures beside the campaign's."""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import yaml

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError
from robot_controller.experiments import laws
from robot_controller.experiments.campaign import executors, identified_world
from robot_controller.experiments.campaign.executors import Task
from robot_controller.experiments.campaign.spec import FIGURES, CampaignSpec, draw, layer, parse_spec, run_seed
from robot_controller.experiments.campaign.store import CAMPAIGN, RESULTS, ResultStore, parts, read_rows


@dataclass(frozen=True)
class CampaignContender:
    label: str  #: the rows' ``controller`` ("" when the spec's controller runs alone)
    spec: str | None  #: controller_type (None: the spec's)


def contenders(spec: CampaignSpec, names: list[str] | None) -> tuple[CampaignContender, ...]:
    """``--controllers A,B``: each checked (its class loads), labelled by its class name; None: the spec's own."""
    if not names:
        return (CampaignContender("", None),)
    chosen = tuple(CampaignContender(laws.label(n), laws.controller_type(n, where="--controllers")) for n in names)
    if len({c.label for c in chosen}) != len(chosen):
        raise ConfigError(f"--controllers: two controllers share a name: {','.join(names)}")
    return chosen


def tasks(
    spec: CampaignSpec,
    chosen: tuple[CampaignContender, ...],
    done: set[tuple[str, int]],
    timeout_s: float | None = None,
) -> list[Task]:
    """The runs still to do, run by run (each run's controllers side by side): the same draws for every controller;
    each held to ``timeout_s`` of wall time (None: the spec's)."""
    timeout_s = spec.timeout_s if timeout_s is None else timeout_s
    stacks = {c.label: spec.base_params(c.spec) for c in chosen}
    out = []
    for run_id in range(spec.runs):
        drawn = draw(spec, run_id)
        seed = run_seed(spec.seed, run_id)
        for c in chosen:
            if (c.label, run_id) not in done:
                task = Task(run_id, c.label, stacks[c.label], drawn, seed, spec.duration_s, timeout_s)
                out.append(replace(task, identify=spec.identify, tune=spec.tune))
    return out


def open_store(spec: CampaignSpec, out: Path, controllers: list[str] | None = None) -> ResultStore:
    """``out``'s rows of this campaign (none yet, or those of a resume).

    :raises ConfigError: ``out`` holds another campaign's, in one line naming what differs (:func:`.store.changed`)
    """
    chosen = contenders(spec, controllers)
    labels = tuple(c.spec or spec.controller or "" for c in chosen)
    about = {
        "spec": spec.text,
        "spec_path": str(spec.path),
        "controllers": [c.label for c in chosen],
        "controller_types": list(labels),
    }
    return ResultStore(out, parts(spec, labels), about)


def run_campaign(
    spec: CampaignSpec,
    out: Path,
    *,
    controllers: list[str] | None = None,
    workers: int | None = None,
    ray_address: str | None = None,
    run_timeout_s: float | None = None,
    say: Callable[[str], None] = print,
    store: ResultStore | None = None,
) -> ResultStore:
    """Run the campaign into ``out`` (resuming what it holds, or what ``store`` opened there) and return its rows;
    each run held to ``run_timeout_s`` of wall time (None: the spec's ``run_timeout_s``, or its default)."""
    chosen = contenders(spec, controllers)
    store = store or open_store(spec, out, controllers)
    todo = tasks(spec, chosen, store.done(), run_timeout_s)
    total = spec.runs * len(chosen)
    if len(todo) < total:
        say(f"resuming: {total - len(todo)} of {total} runs already in {out / 'results.parquet'}")
    if not todo:
        return store
    workers = workers or executors.default_workers()
    rows = executors.run_ray(todo, ray_address) if ray_address else executors.run_local(todo, workers)
    try:
        with Progress(len(todo), total - len(todo)) as progress:
            for row in rows:
                store.add([row])
                progress.advance()
    finally:
        store.compact()
    return store


class Progress:
    """A bar with runs/s and time left on a terminal; else a line every 10 % (``[campaign] 30/60 runs, ...``)."""

    def __init__(self, todo: int, already: int) -> None:
        self.todo, self.already, self.done = todo, already, 0
        self.start = time.monotonic()
        self._bar = None
        self._next_line = 0.1

    def __enter__(self) -> Progress:
        if sys.stdout.isatty():
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

            self._bar = Progress(
                TextColumn("[bold]campaign[/bold]"),
                BarColumn(),
                MofNCompleteColumn(),
                TextColumn("{task.description}"),
                TimeRemainingColumn(),
                TextColumn("left"),
            )
            self._bar.__enter__()
            self._task = self._bar.add_task("", total=self.todo + self.already, completed=self.already)
        return self

    def rate(self) -> float:
        elapsed = time.monotonic() - self.start
        return self.done / elapsed if elapsed > 0 else 0.0

    def advance(self) -> None:
        self.done += 1
        rate = self.rate()
        if self._bar is not None:
            self._bar.update(self._task, advance=1, description=f"{rate:.2f} runs/s")
        elif self.done >= self._next_line * self.todo or self.done == self.todo:
            left = (self.todo - self.done) / rate if rate > 0 else float("nan")
            count = f"{self.already + self.done}/{self.already + self.todo}"
            print(f"[campaign] {count} runs, {rate:.2f} runs/s, {left:.0f} s left", flush=True)
            self._next_line = self.done / self.todo + 0.1

    def __exit__(self, *exc: Any) -> None:
        if self._bar is not None:
            self._bar.__exit__(*exc)


#: The figures set side by side: the campaign's name, the run's metrics.json name.
COMPARED = tuple((key, key) for key in FIGURES[:5]) + (("peak_effort", "peak_torque_nm"),)


def campaign_of(folder: Path) -> tuple[CampaignSpec, dict[str, Any]]:
    """The spec ``folder``'s campaign ran (read again from the text it kept) and what ``campaign.json`` says.

    :raises ConfigError: ``folder`` holds no campaign
    """
    marker = folder / CAMPAIGN
    if not marker.is_file() or not (folder / RESULTS).is_file():
        raise ConfigError(f"{folder}: holds no campaign's results ({CAMPAIGN}, {RESULTS})")
    about = json.loads(marker.read_text())
    return parse_spec(yaml.safe_load(about["spec"]), Path(about["spec_path"]), about["spec"]), about


def replay_row(folder: Path, run_id: int, controller: str | None) -> tuple[CampaignSpec, dict[str, Any], str | None]:
    """The campaign's row of ``run_id`` (under ``controller``, where it compared several) and that controller's
    ``controller_type`` (None: the stack's own)."""
    spec, about = campaign_of(folder)
    labels, types = about["controllers"], about["controller_types"]
    if controller is None and len(labels) > 1:
        raise ConfigError(f"the campaign compared {', '.join(labels)}: say which with --controller")
    label = controller if controller is not None else labels[0]
    if label not in labels:
        raise ConfigError(f"--controller {label}: the campaign ran {', '.join(x or 'its spec' for x in labels)}")
    if not 0 <= run_id < spec.runs:
        raise ConfigError(f"RUN_ID {run_id}: the campaign's runs are 0 to {spec.runs - 1}")
    rows = [r for r in read_rows(folder / RESULTS) if r["run_id"] == run_id and r["controller"] == label]
    if not rows:
        raise ConfigError(f"RUN_ID {run_id}: not in {folder / RESULTS} yet (resume the campaign first)")
    return spec, rows[0], types[labels.index(label)] or None


def replay_layer(spec: CampaignSpec, run_id: int, controller_type: str | None) -> cfg.Params:
    """The parameter layer that makes a run of the graph run ``run_id``: its draws, its noise seed, the controller
    (and, where the campaign identified each world, the model and gains it ran with, found again in process)."""
    drawn, seed = draw(spec, run_id), run_seed(spec.seed, run_id)
    overlay = layer(drawn)
    overlay.setdefault("sensor_node", {})["seed"] = seed
    if controller_type is not None:
        overlay.setdefault("pid_controller", {})["controller_type"] = controller_type
    if spec.identify:
        world = executors.run_params(spec.base_params(controller_type), drawn, seed)
        ran = identified_world.prepared(world, seed, spec.tune, {})["pid_controller"]
        found = {key: value for key, value in ran.items() if world["pid_controller"].get(key) != value}
        overlay.setdefault("pid_controller", {}).update(found)
    return overlay


def compared(row: dict[str, Any], metrics: dict[str, Any]) -> list[tuple[str, float, float, float]]:
    """``(figure, campaign's, replay's, difference as a fraction of the campaign's)`` for each figure both have."""
    out = []
    for ours, theirs in COMPARED:
        a, b = row.get(ours), metrics.get(theirs)
        if a is not None and b is not None:
            out.append((ours, float(a), float(b), (float(b) - float(a)) / float(a) if a else float("nan")))
    return out
