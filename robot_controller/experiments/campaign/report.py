"""A campaign's report, ``campaign.md`` and its plots, from its rows: each figure's distribution, the pass rate against
the spec's ``pass:`` bounds with its Wilson interval, the worst runs with their draws, and which varied parameter
drives the error (Spearman's rank correlation)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller.experiments.campaign.spec import FIGURES, CampaignSpec
from robot_controller.experiments.reporting import pyplot

WORST_SHOWN = 5
#: z of a two-sided 95 % interval.
Z95 = 1.959963984540054


def wilson_interval(passed: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a proportion ``passed``/``n`` (95 % by default); (0, 1) when n is 0."""
    if n == 0:
        return 0.0, 1.0
    p = passed / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


def headline(rows: list[dict[str, Any]]) -> str:
    """The figure runs are ranked by: the worst joint's tracking RMS (rad, or m on an arm of sliders alone)."""
    return "tracking_rms_rad" if any(r.get("tracking_rms_rad") is not None for r in rows) else "tracking_rms_m"


def passes(row: dict[str, Any], bounds: dict[str, float]) -> bool:
    """A run that finished, its law with no fault, and kept every bound (a bound on a figure the arm lacks, as rad
    on a slider: kept)."""
    if row.get("status") != "ok" or row.get("law_fault"):
        return False
    return all(row.get(k) is None or row[k] <= bound for k, bound in bounds.items())


def draw_columns(spec: CampaignSpec, rows: list[dict[str, Any]]) -> list[str]:
    """The rows' columns that hold draws, in the spec's order."""
    keys = [v.key for v in spec.vary]
    names = dict.fromkeys(c for r in rows for c in r)
    return [c for k in keys for c in names if c == k or c.startswith(k + "[")]


def sensitivity(spec: CampaignSpec, rows: list[dict[str, Any]], target: str) -> list[dict[str, Any]]:
    """Each numeric varied column's Spearman rank correlation with ``target`` over the runs that finished, strongest
    first: ``{"parameter", "rho", "p_value", "runs"}`` (a constant column or one of texts: skipped)."""
    from scipy.stats import spearmanr

    ok = [r for r in rows if r.get("status") == "ok" and r.get(target) is not None]
    out = []
    for column in draw_columns(spec, rows):
        values = [r.get(column) for r in ok]
        if len(ok) < 3 or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
            continue
        x, y = np.asarray(values, float), np.asarray([r[target] for r in ok], float)
        if np.ptp(x) == 0 or np.ptp(y) == 0:
            continue
        rho, p_value = spearmanr(x, y)
        out.append({"parameter": column, "rho": float(rho), "p_value": float(p_value), "runs": len(ok)})
    return sorted(out, key=lambda s: -abs(s["rho"]))


def write_report(spec: CampaignSpec, rows: list[dict[str, Any]], out: Path, controllers: list[str]) -> Path:
    """``out/campaign.md`` and its plots (``distributions.png``, ``sensitivity.png``)."""
    target = headline(rows)
    groups = {c: [r for r in rows if r["controller"] == c] for c in controllers}
    lines = [f"# Campaign: {spec.runs} runs of {spec.duration_s:g} s on {spec.robot}", ""]
    lines += [f"Seed {spec.seed}; each run's draws and noise seed follow from it and the run's id alone.", ""]
    lines += ["Varied:", ""] + [f"- `{v.key}`: {_describe(v)}" for v in spec.vary] + [""]
    if spec.identify:
        tuned = f", then its gains designed for `{spec.tune}` and kept where verified better" if spec.tune else ""
        lines += [
            f"Each world identified before its run, as its user would (`identify`'s fits, in process){tuned}.",
            "",
        ]
    lines += _figures_table(groups, target)
    lines += _pass_section(spec, groups)
    if len(controllers) == 2:
        lines += _paired_section(groups, controllers, target)
    lines += _worst_section(spec, rows, target, out)
    lines += _sensitivity_section(spec, groups, target, out)
    failed = [r for r in rows if r.get("status") != "ok"]
    lines += _listed("Failed and timed-out runs", [(r, r.get("reason", "")) for r in failed])
    faulted = [(r, r["law_fault"]) for r in rows if r.get("status") == "ok" and r.get("law_fault")]
    lines += _listed("Law faults (the run ended in a controlled stop)", faulted)
    retried = [(r, f"first try {r['first_failure']}") for r in rows if r.get("first_failure")]
    lines += _listed("Runs tried twice", retried)
    plot_distributions(groups, out / "distributions.png")
    lines += [
        "## Files",
        "",
        "- `results.parquet`: one row per run (run_id, controller, each draw, each figure, status)",
    ]
    lines += ["- `distributions.png`, `sensitivity.png`", ""]
    path = out / "campaign.md"
    path.write_text("\n".join(lines))
    return path


def _who(row: dict[str, Any]) -> str:
    return f" ({row['controller']})" if row.get("controller") else ""


def _describe(v) -> str:
    shape = {
        "uniform": "uniform on [{}, {}]",
        "loguniform": "log-uniform on [{}, {}]",
        "normal": "normal, mean {}, σ {}",
    }
    text = f"one of {list(v.args)}" if v.kind == "choice" else shape[v.kind].format(*(f"{a:g}" for a in v.args))
    return text + (", drawn per joint" if v.per_joint else "")


def _quantiles(values: list[float]) -> str:
    if not values:
        return "| – | – | – | – |"
    a = np.asarray(values, float)
    return "| " + " | ".join(f"{x:.4g}" for x in (np.median(a), np.percentile(a, 95), a.max(), a.mean())) + " |"


def _figures_table(groups: dict[str, list[dict]], target: str) -> list[str]:
    lines = ["## Figures", "", "Over the runs that finished: median, 95th percentile, largest, mean.", ""]
    lines += ["| controller | figure | median | p95 | max | mean |", "|---|---|---:|---:|---:|---:|"]
    for name, rows in groups.items():
        ok = [r for r in rows if r.get("status") == "ok"]
        for key in FIGURES:
            values = [r[key] for r in ok if r.get(key) is not None]
            if values:
                lines.append(f"| {name or 'default'} | {key} | " + _quantiles(values)[2:])
        lines.append(f"| {name or 'default'} | runs finished | {len(ok)} of {len(rows)} | | | |")
    return lines + [""]


def _pass_section(spec: CampaignSpec, groups: dict[str, list[dict]]) -> list[str]:
    if not spec.pass_bounds:
        return ["## Pass rate", "", "No `pass:` bounds in the spec.", ""]
    bounds = ", ".join(f"{k} ≤ {v:g}" for k, v in spec.pass_bounds.items())
    lines = ["## Pass rate", "", f"A run passes when it finished and kept {bounds}; 95 % Wilson score interval.", ""]
    for name, rows in groups.items():
        passed = sum(passes(r, spec.pass_bounds) for r in rows)
        lo, hi = wilson_interval(passed, len(rows))
        rate = passed / len(rows) if rows else float("nan")
        lines.append(
            f"- {name or 'the controller'}: {passed} of {len(rows)} = {rate:.1%} (95 % CI {lo:.1%} – {hi:.1%})"
        )
    return lines + [""]


def _paired_section(groups: dict[str, list[dict]], names: list[str], target: str) -> list[str]:
    a, b = names
    by_run = {
        name: {r["run_id"]: r.get(target) for r in rows if r.get("status") == "ok"} for name, rows in groups.items()
    }
    common = sorted(set(by_run[a]) & set(by_run[b]))
    if not common:
        return []
    ratio = np.asarray([by_run[b][k] / by_run[a][k] for k in common if by_run[a][k]], float)
    better = sum(by_run[a][k] < by_run[b][k] for k in common)
    return [
        "## Paired on the same draws",
        "",
        f"On the {len(common)} runs both finished: {a} tracked better ({target}) in {better} "
        f"({better / len(common):.0%}); {b}/{a} median ratio {np.median(ratio):.3g} "
        f"(5–95 %: {np.percentile(ratio, 5):.3g} – {np.percentile(ratio, 95):.3g}).",
        "",
    ]


def _worst_section(spec: CampaignSpec, rows: list[dict], target: str, out: Path) -> list[str]:
    ok = sorted((r for r in rows if r.get("status") == "ok" and r.get(target) is not None), key=lambda r: -r[target])
    columns = draw_columns(spec, rows)
    lines = [f"## Worst runs (by {target})", ""]
    lines += ["| run | " + " | ".join([target, "peak_effort_ratio", "faults", *columns]) + " |"]
    lines += ["|---" * (4 + len(columns)) + "|"]
    for r in ok[:WORST_SHOWN]:
        cells = [f"{r[target]:.4g}", f"{r['peak_effort_ratio']:.3g}", str(r["faults"])]
        cells += [_cell(r.get(c)) for c in columns]
        lines.append(f"| {r['run_id']}{_who(r)} | " + " | ".join(cells) + " |")
    if ok:
        worst = ok[0]
        who = f" --controller {worst['controller']}" if worst.get("controller") else ""
        lines += ["", "Replay the worst through the ROS graph on sim time:", ""]
        lines += [
            f"    robot-controller campaign replay {out} {worst['run_id']}{who} --out runs/replay-{worst['run_id']}"
        ]
    return lines + [""]


def _cell(value: Any) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def _sensitivity_section(spec: CampaignSpec, groups: dict[str, list[dict]], target: str, out: Path) -> list[str]:
    lines = [
        "## Sensitivity",
        "",
        f"Which varied parameter drives {target}: Spearman's rank correlation ρ (scipy.stats.spearmanr) between each "
        "draw and the figure over the runs that finished, strongest first. ρ near ±1: the figure rises (falls) with "
        "the parameter; p: the chance of so strong a ρ if they were unrelated.",
        "",
    ]
    ranked_by_group = {}
    for name, rows in groups.items():
        ranked = sensitivity(spec, rows, target)
        ranked_by_group[name] = (rows, ranked)
        if len(groups) > 1:
            lines += [f"{name}:", ""]
        lines += ["| rank | parameter | ρ | p |", "|---:|---|---:|---:|"]
        lines += [
            f"| {i + 1} | `{s['parameter']}` | {s['rho']:+.3f} | {s['p_value']:.2g} |" for i, s in enumerate(ranked)
        ]
        lines.append("")
    plot_sensitivity(ranked_by_group, target, out / "sensitivity.png")
    return lines + ["![sensitivity](sensitivity.png) ![distributions](distributions.png)", ""]


def _listed(title: str, entries: list[tuple[dict, str]]) -> list[str]:
    """A section listing runs with what was said of each (the first 20)."""
    if not entries:
        return []
    lines = [f"## {title}", ""] + [f"- run {r['run_id']}{_who(r)}: {said}" for r, said in entries[:20]]
    return lines + [f"- … and {len(entries) - 20} more (results.parquet)" if len(entries) > 20 else "", ""]


def plot_distributions(groups: dict[str, list[dict]], path: Path) -> None:
    plt = pyplot()
    keys = [k for k in FIGURES if any(r.get(k) is not None for rows in groups.values() for r in rows)]
    fig, axes = plt.subplots(1, len(keys), figsize=(3.2 * len(keys), 3), squeeze=False)
    for ax, key in zip(axes[0], keys, strict=True):
        for name, rows in groups.items():
            values = [r[key] for r in rows if r.get("status") == "ok" and r.get(key) is not None]
            if values:
                ax.hist(values, bins=min(30, max(5, len(values) // 4)), alpha=0.6, label=name or None)
        ax.set_title(key, fontsize=9)
        ax.set_ylabel("runs")
    if len(groups) > 1:
        axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def plot_sensitivity(ranked_by_group: dict[str, tuple[list[dict], list[dict]]], target: str, path: Path) -> None:
    """The figure against each of the (up to) three strongest draws, one panel each."""
    plt = pyplot()
    first = next(iter(ranked_by_group.values()))[1][:3]
    fig, axes = plt.subplots(1, max(1, len(first)), figsize=(4 * max(1, len(first)), 3.2), squeeze=False)
    for ax, s in zip(axes[0], first, strict=False):
        for name, (rows, _) in ranked_by_group.items():
            ok = [r for r in rows if r.get("status") == "ok" and r.get(target) is not None]
            ax.scatter([r[s["parameter"]] for r in ok], [r[target] for r in ok], s=10, alpha=0.7, label=name or None)
        ax.set_xlabel(s["parameter"], fontsize=8)
        ax.set_ylabel(target, fontsize=8)
        ax.set_title(f"ρ = {s['rho']:+.2f}", fontsize=9)
    if len(ranked_by_group) > 1 and first:
        axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
