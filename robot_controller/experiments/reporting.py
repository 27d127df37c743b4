"""What the experiments write for people and files: ``results.json`` (flat numbers), tables, numbers
in them, ``report.md``, and plots (matplotlib on the Agg backend)."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from robot_controller.scoring import report

Progress = Callable[[str], None]


def write_results(out: Path, values: dict[str, Any]) -> dict[str, Any]:
    """``results.json``: flat keys, numbers (NaN, a figure that could not be measured, as null).
    Returns what it wrote."""
    flat: dict[str, Any] = {}
    for key, value in values.items():
        if isinstance(value, bool | np.bool_ | int | np.integer):
            value = int(value)
        elif isinstance(value, float | np.floating):
            value = float(value)
        elif value is not None:
            raise TypeError(f"results.json: {key} is {type(value).__name__}, not a number")
        flat[key] = value
    report.write_metrics(out / "results.json", flat)
    return report.json_safe(flat)


def fmt(value: Any, spec: str = "{:.3g}", missing: str = "—") -> str:
    """A number for a table; NaN or None as ``missing``."""
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return missing
    return spec.format(value)


def cells(values: dict[str, Any], columns, prefix: str = "", scale: float = 1.0) -> list[str]:
    """``fmt`` of ``values[prefix + key]`` (times ``scale``) for each ``(key, spec[, missing])`` of ``columns``."""
    return [
        fmt(values[prefix + key] * scale if scale != 1.0 else values[prefix + key], *rest) for key, *rest in columns
    ]


def table(headers: str | list[str], rows: list[list[str]]) -> str:
    """A markdown table; ``headers`` a list or one string, ``"a | b | c"``."""
    if isinstance(headers, str):
        headers = headers.split(" | ")
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def write_report(out: Path, text: str) -> Path:
    path = out / "report.md"
    path.write_text(text.rstrip() + "\n")
    return path


def pyplot():
    """matplotlib's pyplot on the Agg backend (files only, no display)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def label_axes(ax, xlabel: str | None = None, ylabel: str | None = None, legend: int | None = 8) -> None:
    """Axis labels, a light grid and the legend (``legend``: its font size; None: no legend)."""
    if xlabel is not None:
        ax.set_xlabel(xlabel)
    if ylabel is not None:
        ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3)
    if legend is not None:
        ax.legend(fontsize=legend)


def save(fig, path: Path, title: str) -> None:
    """``fig`` with its title, written to ``path`` and closed."""
    fig.suptitle(title)
    fig.savefig(path, dpi=110)
    pyplot().close(fig)
