"""Run k's draws, from the campaign's seed and k alone: the same wherever and whenever run k runs, and the same for
every controller compared. Each varied key draws from a stream of its own, so adding a key leaves the others'."""

from __future__ import annotations

import zlib
from typing import Any

import numpy as np

from robot_controller.experiments.campaign.spec import CampaignSpec, Vary


def run_seed(campaign_seed: int, run_id: int) -> int:
    """Run ``run_id``'s noise seed (the sensor's), a 31-bit integer the parameter schema accepts."""
    return int(np.random.SeedSequence([campaign_seed, run_id]).generate_state(1)[0] >> 1)


def draw(spec: CampaignSpec, run_id: int) -> dict[str, Any]:
    """``{node.parameter: value}`` for run ``run_id``: a number, or a list of one per joint (``per_joint``)."""
    return {v.key: _draw_one(v, spec.seed, run_id, spec.joint_count) for v in spec.vary}


def _draw_one(vary: Vary, campaign_seed: int, run_id: int, joint_count: int) -> Any:
    rng = np.random.default_rng(np.random.SeedSequence([campaign_seed, run_id, zlib.crc32(vary.key.encode())]))
    size = joint_count if vary.per_joint else 1
    if vary.kind == "choice":
        picked = [vary.args[int(i)] for i in rng.integers(len(vary.args), size=size)]
        return picked if vary.per_joint else picked[0]
    a, b = vary.args
    if vary.kind == "uniform":
        values = rng.uniform(a, b, size)
    elif vary.kind == "loguniform":
        values = np.exp(rng.uniform(np.log(a), np.log(b), size))
    else:  # normal, clipped to the parameter's range (a noise σ below 0 is no world)
        values = rng.normal(a, b, size)
        lo = -np.inf if vary.minimum is None else vary.minimum
        hi = np.inf if vary.maximum is None else vary.maximum
        values = np.clip(values, lo, hi)
    floats = [float(x) for x in values]
    return floats if vary.per_joint else floats[0]


def columns(drawn: dict[str, Any]) -> dict[str, Any]:
    """The draws as a row's columns: a per-joint list becomes ``key[0]``, ``key[1]``, …"""
    out: dict[str, Any] = {}
    for key, value in drawn.items():
        if isinstance(value, list):
            out.update({f"{key}[{j}]": v for j, v in enumerate(value)})
        else:
            out[key] = value
    return out


def layer(drawn: dict[str, Any]) -> dict[str, dict[str, Any]]:
    """The draws as a parameter layer ``{node: {parameter: value}}``, to merge over the campaign's stack."""
    out: dict[str, dict[str, Any]] = {}
    for key, value in drawn.items():
        node, _, name = key.partition(".")
        out.setdefault(node, {})[name] = value
    return out
