"""``tactile-bt compare``: runs side by side — their reports in ``compare.md``, their feature
errors against mission time overlaid in ``compare.png``.

A run is an output directory of ``tactile-bt run`` or ``replay`` (``report.json``, ``log.npz``);
a sweep's output directory kept with ``--keep-runs`` counts as every run under its ``runs/``.

Layer: experiments.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from tactile_bt import defaults
from tactile_bt.errors import TactileBtError
from tactile_bt.mission.report import MissionReport

__all__ = ["ComparedRun", "find_runs", "format_compare", "plot_compare", "write_compare"]

#: The features of the paper's Tables I-III, with their units and how the figure scales them.
FEATURES = {
    "pressure_pa": ("Pa", "pressure error\n(units of target 2 kPa)", 1.0 / defaults.TARGET_PRESSURE_PA),
    "cop_x_px": ("px", "COP x error (px)", 1.0),
    "cop_y_px": ("px", "COP y error (px)", 1.0),
    "orientation_rad": ("rad", "orientation error (deg)", 180.0 / math.pi),
}


@dataclass
class ComparedRun:
    """One run of a comparison: its label (the directory as given, or ``SWEEP/RUN_ID``), its
    directory and its report."""

    label: str
    path: Path
    report: MissionReport

    def log(self) -> dict | None:
        """The run's ``log.npz`` (None when it has none)."""
        path = self.path / "log.npz"
        if not path.exists():
            return None
        with np.load(path) as data:
            return {k: data[k] for k in ("t", *(f"error_{name}" for name in FEATURES)) if k in data}


def find_runs(dirs) -> list[ComparedRun]:
    """The runs in ``dirs``: a directory with ``report.json`` is one run, a sweep's output with
    ``runs/`` is each run under it (sorted by name). Raises :class:`TactileBtError` naming a
    directory that holds neither, or when fewer than two runs are found."""
    runs = []
    for d in dirs:
        path = Path(d)
        if (path / "report.json").is_file():
            runs.append(ComparedRun(str(d), path, MissionReport.load(path)))
            continue
        kept = sorted(p.parent for p in (path / "runs").glob("*/report.json")) if (path / "runs").is_dir() else []
        if not kept:
            hint = (" (a sweep keeps its runs with --keep-runs)" if (path / "results.csv").exists()
                    else " (the output of 'tactile-bt run', 'replay' or 'sweep --keep-runs')")
            what = "does not exist" if not path.exists() else "holds no report.json and no runs/*/report.json"
            raise TactileBtError(f"compare: {d} {what}{hint}")
        runs.extend(ComparedRun(f"{d}/{p.name}", p, MissionReport.load(p)) for p in kept)
    if len(runs) < 2:
        raise TactileBtError(f"compare: {len(runs)} run found in {', '.join(map(str, dirs))}; give at least two")
    return runs


def _fmt(value, scale: float = 1.0, digits: int = 3) -> str:
    if value is None or not math.isfinite(float(value)):
        return "–"
    return f"{float(value) * scale:.{digits}g}"


def _accuracy(r: MissionReport) -> str:
    """Path error of a cable mission or accuracy of a scan, in mm."""
    if r.path_error_m and r.path_error_m.get("mean") is not None:
        p = r.path_error_m
        return f"path error mean {_fmt(p.get('mean'), 1e3)} mm, max {_fmt(p.get('max'), 1e3)} mm"
    rec = r.reconstruction
    if rec and rec.get("chamfer_m") is not None:
        return (f"chamfer {_fmt(rec.get('chamfer_m'), 1e3)} mm, Hausdorff {_fmt(rec.get('hausdorff_m'), 1e3)} mm, "
                f"coverage {_fmt(rec.get('coverage'))}")
    return "–"


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def format_compare(runs: list[ComparedRun]) -> str:
    """``compare.md``: the outcome of every run, then one table per feature with the paper's
    Table I-III columns (steady-state error, standard deviation, response time)."""
    lines = [f"# {len(runs)} runs compared", "",
             "| run | tree | scene | seed | status | reason | mission time (s) | ticks | real time | accuracy |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for run in runs:
        r = run.report
        lines.append("| " + " | ".join(_cell(c) for c in (
            run.label, Path(r.tree).stem, Path(r.scene).stem if r.scene else "–", r.seed if r.seed is not None else "–",
            r.status, r.reason or "–", f"{r.sim_time_s:.2f}", r.ticks, f"{r.real_time_factor:.1f}x",
            _accuracy(r))) + " |")
    for name, (unit, _, _) in FEATURES.items():
        lines += ["", f"## {name}", "",
                  f"| run | steady-state error ({unit}) | std ({unit}) | response time (s) |", "|---|---|---|---|"]
        for run in runs:
            m = run.report.metrics.get(name)
            cells = ("not controlled", "–", "–") if m is None else (
                _fmt(m.steady_state_error, digits=4), _fmt(m.std, digits=4), _fmt(m.response_time_s))
            lines.append("| " + " | ".join(_cell(c) for c in (run.label, *cells)) + " |")
    lines += ["", "Errors against mission time: compare.png.", ""]
    return "\n".join(lines)


def plot_compare(runs: list[ComparedRun], path: str | Path | None = None):
    """``compare.png``: each feature's error against mission time, one line per run."""
    import matplotlib

    if path is not None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(FEATURES), 1, figsize=(9, 9), sharex=True, constrained_layout=True)
    many = len(runs) > 10
    for i, run in enumerate(runs):
        log = run.log()
        if log is None:
            continue
        colour = f"C{i % 10}"
        for ax, (name, (_, _, scale)) in zip(axes, FEATURES.items()):
            key = f"error_{name}"
            if key in log:
                ax.plot(log["t"], log[key] * scale, color=colour, lw=0.6 if many else 0.8, alpha=0.6 if many else 0.8,
                        label=run.label if ax is axes[0] else None)
    for ax, (_, label, _) in zip(axes, FEATURES.values()):
        ax.set_ylabel(label)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("mission time (s)")
    if not many:
        axes[0].legend(fontsize=7, loc="upper right")
    fig.suptitle(f"feature errors of {len(runs)} runs", fontsize=10)
    if path is not None:
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return fig


def write_compare(dirs, out: str | Path) -> tuple[Path, Path]:
    """Compare the runs in ``dirs``; writes ``compare.md`` and ``compare.png`` into ``out``
    (created) and returns their paths."""
    from tactile_bt.arguments import check_output_dir

    runs = find_runs(dirs)
    out = check_output_dir(out)
    md, png = out / "compare.md", out / "compare.png"
    md.write_text(format_compare(runs))
    plot_compare(runs, png)
    return md, png
