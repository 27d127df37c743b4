"""One run of a campaign again, alone, through the full ROS graph: the campaign's stack, the run's draws, its noise
seed and the controller, as a parameter file the run loads; then its figures beside the campaign's."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import yaml

from robot_controller import parameters as cfg
from robot_controller.core.errors import ConfigError
from robot_controller.experiments.campaign.spec import FIGURES, CampaignSpec, draw, layer, parse_spec, run_seed
from robot_controller.experiments.campaign.store import CAMPAIGN, RESULTS, read_rows

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
    """The parameter layer that makes a run of the graph run ``run_id``: its draws, its noise seed, the controller."""
    overlay = layer(draw(spec, run_id))
    overlay.setdefault("sensor_node", {})["seed"] = run_seed(spec.seed, run_id)
    if controller_type is not None:
        overlay.setdefault("pid_controller", {})["controller_type"] = controller_type
    return overlay


def compared(row: dict[str, Any], metrics: dict[str, Any]) -> list[tuple[str, float, float, float]]:
    """``(figure, campaign's, replay's, difference as a fraction of the campaign's)`` for each figure both have."""
    out = []
    for ours, theirs in COMPARED:
        a, b = row.get(ours), metrics.get(theirs)
        if a is not None and b is not None:
            out.append((ours, float(a), float(b), (float(b) - float(a)) / float(a) if a else float("nan")))
    return out
