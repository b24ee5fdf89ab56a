"""What a sweep shows at its end: every metric against the grid values (``summary.png``) and
the printed summary.

Layer: experiments.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from tactile_bt.units import format_value

from tactile_bt.experiments.sweep_spec import SweepSpec, si_value

__all__ = ["SECTIONS", "plot_summary", "format_summary", "metric_columns", "NOT_PLOTTED", "SUMMARY_PNG", "MAX_PLOTTED"]

#: Sections of the report flattened into ``section.key`` columns.
SECTIONS = ("metrics", "path_error_m", "path_error_cop_m", "reconstruction")
#: Report figures that are settings, not outcomes: in the table, not in the plot.
NOT_PLOTTED = (".band", ".window_s")
SUMMARY_PNG = "summary.png"
MAX_PLOTTED = 24


# --------------------------------------------------------------------------- summary
def metric_columns(rows: list[dict[str, str]], plotted: bool = False) -> list[str]:
    """The columns of report figures (``metrics.*``, ``path_error_m.*``, ...) that hold a number
    in some row; ``plotted`` leaves out the settings (``band``, ``window_s``)."""
    columns: dict[str, None] = {}
    for row in rows:
        for k, v in row.items():
            if k.split(".", 1)[0] in SECTIONS and "." in k and _float(v) is not None:
                if not (plotted and k.endswith(NOT_PLOTTED)):
                    columns[k] = None
    return list(columns)


def _float(text: Any) -> float | None:
    if text is None or text == "":
        return None
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


def _x_key(spec: SweepSpec) -> str | None:
    """The grid key along the plots' x axis: the numeric one with the most values."""
    numeric = [(len(v), k) for k, v in spec.grid
               if all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (si_value(k, u) for u in v))]
    if numeric:
        return max(numeric, key=lambda p: p[0])[1]
    return spec.grid_keys[0] if spec.grid else None


def plot_summary(spec: SweepSpec, runs: list, rows: list[dict[str, str]], path: str | Path) -> Path | None:
    """Every metric against the grid values: the seeds as dots, their mean as a line, one line per
    scene and combination of the other grid keys. None when no run has a metric.

    ``runs`` are the sweep's :class:`~tactile_bt.experiments.sweep.Run` (matched to ``rows`` by
    ``run_id``)."""
    columns = metric_columns(rows, plotted=True)[:MAX_PLOTTED]
    if not columns:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    by_id = {r.run_id: r for r in runs}
    x_key = _x_key(spec)
    x_values = [si_value(x_key, v) for v in dict(spec.grid)[x_key]] if x_key else [label for label, _ in spec.scenes]
    numeric_x = x_key is not None and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in x_values)
    log_x = numeric_x and min(x_values) > 0 and max(x_values) / min(x_values) >= 100

    def position(run) -> float:
        x = si_value(x_key, dict(run.values)[x_key]) if x_key else run.scene_label
        return float(x) if numeric_x else float(x_values.index(x))

    def series(run) -> str:
        parts = [] if x_key is None else [run.scene_label] * (len(spec.scenes) > 1)
        parts += [f"{k}={format_value(v)}" for k, v in run.values if k != x_key]
        return ", ".join(parts)

    groups: dict[str, list[tuple]] = {}
    for row in rows:
        run = by_id.get(row["run_id"])
        if run is not None and row.get("status") != "error":
            groups.setdefault(series(run), []).append((run, row))
    ncols = min(3, len(columns))
    nrows = math.ceil(len(columns) / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.2 * ncols, 3.0 * nrows), squeeze=False, constrained_layout=True)
    for ax, column in zip(axes.flat, columns):
        for colour, (name, members) in enumerate(groups.items()):
            xs = np.array([position(run) for run, _ in members])
            ys = np.array([_float(row.get(column)) if _float(row.get(column)) is not None else np.nan
                           for _, row in members])
            c = f"C{colour % 10}"
            ax.plot(xs, ys, "o", color=c, alpha=0.35, ms=4)
            ux = np.unique(xs)
            means = [np.nanmean(ys[xs == u]) if np.isfinite(ys[xs == u]).any() else np.nan for u in ux]
            ax.plot(ux, means, "-", color=c, lw=1.4, label=name or None)
        ax.set_title(column, fontsize=9)
        if log_x:
            ax.set_xscale("log")
        if not numeric_x:
            ax.set_xticks(range(len(x_values)), [format_value(x) for x in x_values], fontsize=8,
                          rotation=20 if len(x_values) > 3 else 0)
        ax.set_xlabel(x_key or "scene", fontsize=8)
        ax.tick_params(labelsize=8)
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(columns):]:
        ax.set_visible(False)
    if any(name for name in groups):
        axes.flat[0].legend(fontsize=7)
    seeds = len(spec.seeds)
    fig.suptitle(f"{spec.name}: {spec.tree_label}, {seeds} seed{'s' if seeds != 1 else ''} per point "
                 "(dots: seeds, line: mean)", fontsize=10)
    path = Path(path)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def format_summary(result, max_metrics: int = 4) -> str:
    """A table per scene and grid combination of a :class:`~tactile_bt.experiments.sweep.SweepResult`:
    runs, errors and the mean of a few metrics over the seeds (all of them are in ``results.csv``)."""
    spec = result.spec
    by_id = {r.run_id: r for r in result.runs}
    preferred = [c for c in metric_columns(result.rows, plotted=True)
                 if c.endswith((".steady_state_error", ".std", ".mean", ".coverage", ".chamfer_m"))]
    shown = preferred[:max_metrics]
    keys = spec.grid_keys
    head = ["scene", *keys, "runs", "errors", *shown]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    groups: dict[str, tuple] = {}
    for row in result.rows:
        run = by_id[row["run_id"]]
        key = json.dumps([run.scene_label, run.values], default=str)  # values may be lists
        groups.setdefault(key, (run, []))[1].append(row)
    for run, members in groups.values():
        cells = [run.scene_label, *(format_value(v) for _, v in run.values), str(len(members)),
                 str(sum(m.get("status") == "error" for m in members))]
        for column in shown:
            numbers = [_float(m.get(column)) for m in members]
            numbers = [x for x in numbers if x is not None and math.isfinite(x)]
            cells.append(f"{sum(numbers) / len(numbers):.4g}" if numbers else "–")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
