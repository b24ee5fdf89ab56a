"""Reproduce the paper's Tables I–III and Figs. 8–11 on the simulator (``tactile-bt paper``).

Each experiment is a tree from ``trees/`` on a scene from ``sim/``, run for 20 trials with
seeds 0–19 (new sensor characteristics and noise each trial), the paper's protocol (Sec. V).
The metrics are those of :mod:`tactile_bt.mission.metrics`; the pressure is reported in units of the
target (the paper's p = 1 = 2 kPa), positions in tactels (px).

Layer: experiments.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tactile_bt import defaults, shipped

__all__ = ["Experiment", "EXPERIMENTS", "run_paper", "format_tables"]



@dataclass(frozen=True)
class Experiment:
    """One row group of the paper's tables: a tree on a scene, and the paper's numbers.

    ``paper`` maps a metric name (``pressure_pa``, ``cop_x_px``, ``cop_y_px``) to
    ``(steady-state error, std, response time s)`` in the paper's units.
    """

    key: str
    table: str
    label: str
    tree: str
    scene: str
    overrides: tuple[str, ...] = ()
    paper: dict = field(default_factory=dict)


EXPERIMENTS = (
    Experiment("force_pen", "I", "rigid pen", "trees/force_hold.yaml", "sim/pen.yaml",
               paper={"pressure_pa": (0.0032, 0.039, 2.5)}),
    Experiment("force_box", "I", "toy box", "trees/force_hold.yaml", "sim/toy_box.yaml",
               paper={"pressure_pa": (0.0026, 0.039, 2.0)}),
    Experiment("force_ball", "I", "soft ball", "trees/force_hold.yaml", "sim/soft_ball.yaml",
               paper={"pressure_pa": (0.0010, 0.043, 2.0)}),
    Experiment("position", "II", "contact position", "trees/centre.yaml", "sim/point_contact.yaml",
               paper={"cop_x_px": (-0.0027, 0.0440, 2.0), "cop_y_px": (-0.0406, 0.0509, 2.0)}),
    Experiment("hybrid", "III", "position and force", "trees/hybrid.yaml", "sim/point_contact.yaml",
               paper={"cop_x_px": (0.0041, 0.1146, 1.8), "cop_y_px": (0.0082, 0.1158, 1.8),
                      "pressure_pa": (-0.0014, 0.1335, 2.0)}),
)


def _scale(metric: str) -> float:
    """Factor from our units to the paper's: pressure in units of the 2 kPa target."""
    return 1.0 / defaults.TARGET_PRESSURE_PA if metric == "pressure_pa" else 1.0


def _trial(args) -> dict:
    """One run (in a worker process); returns the metrics and the logs needed for the figures."""
    exp, seed, duration, keep_log = args
    from tactile_bt.mission.run import run_mission

    result = run_mission(shipped.path(exp.tree), shipped.path(exp.scene), duration=duration, seed=seed,
                         overrides=list(exp.overrides))
    r = result.summary
    out = {"key": exp.key, "seed": seed, "status": r.status,
           "metrics": {k: m.to_dict() for k, m in r.metrics.items()}, "wall_time_s": r.wall_time_s}
    if keep_log:
        keys = ("t", "pressure_pa", "pressure_raw_pa", "error_pressure_pa", "error_cop_x_px",
                "error_cop_y_px", "rotation", "position_m")
        out["log"] = {k: result.log[k] for k in keys}
    return out


def run_paper(trials: int = 20, duration: float = 22.0, workers: int | None = None,
              experiments=EXPERIMENTS, executor=None, progress=None) -> dict:
    """Run every experiment ``trials`` times; returns per-experiment averages and one log each.

    The mission runs ``duration`` s so that the 20 s window after the approach is complete. The
    runs go to ``executor`` (:mod:`tactile_bt.experiments.executors`; default: the one of
    ``workers``, as ``--workers``); ``progress(done, total)`` is called as they finish.
    """
    from tactile_bt.experiments.executors import make_executor, run_all

    jobs = [(exp, seed, duration, seed == 0) for exp in experiments for seed in range(trials)]
    if executor is None:
        with make_executor(workers) as own:
            runs = run_all(_trial, jobs, own, progress)
    else:
        runs = run_all(_trial, jobs, executor, progress)
    results = {}
    for exp in experiments:
        mine = [r for r in runs if r["key"] == exp.key]
        rows = {}
        for metric in exp.paper:
            values = np.array([[r["metrics"].get(metric, {}).get(k, np.nan)
                                for k in ("steady_state_error", "std", "response_time_s")] for r in mine])
            values[:, :2] *= _scale(metric)
            rows[metric] = {
                "ours": np.nanmean(values, axis=0).tolist(),
                "ours_worst_response_s": float(np.nanmax(values[:, 2])),
                "unsettled_trials": int(np.isnan(values[:, 2]).sum()),
                "paper": list(exp.paper[metric]),
            }
        results[exp.key] = {
            "table": exp.table, "label": exp.label, "tree": exp.tree, "scene": exp.scene,
            "trials": len(mine), "failed_trials": sum(r["status"] not in ("success", "completed") for r in mine),
            "rows": rows, "log": next(r["log"] for r in mine if "log" in r),
        }
    return results


def format_tables(results: dict) -> str:
    """Markdown tables next to the paper's values."""
    names = {"pressure_pa": "force", "cop_x_px": "X", "cop_y_px": "Y"}
    units = {"pressure_pa": "", "cop_x_px": " px", "cop_y_px": " px"}
    lines = []
    for table, title in (("I", "Normal force control"), ("II", "Contact position control"),
                         ("III", "Hybrid position/force control")):
        lines += [f"**Table {table}: {title}** (ours: mean of the trials; paper in brackets)", "",
                  "| run | steady-state error | standard deviation | response time |", "|---|---|---|---|"]
        for r in results.values():
            if r["table"] != table:
                continue
            for metric, row in r["rows"].items():
                label = r["label"] if table == "I" else names[metric]
                (e, s, t), (pe, ps, pt) = row["ours"], row["paper"]
                u = units[metric]
                lines.append(f"| {label} | {e:+.4f}{u} ({pe:+.4f}) | {s:.4f}{u} ({ps:.4f}) | "
                             f"{t:.2f} s ({pt:g} s) |")
        lines.append("")
    return "\n".join(lines)


ROLL = Experiment("roll", "fig11", "rolling", "trees/roll.yaml", "sim/roll_ball.yaml")


def run_roll(duration: float = 12.0, seed: int = 0) -> dict:
    """The rolling experiment of Fig. 11: one run; COP, rotation about the pad axes, pressure."""
    from scipy.spatial.transform import Rotation

    from tactile_bt.mission.run import run_mission

    result = run_mission(shipped.path(ROLL.tree), shipped.path(ROLL.scene), duration=duration, seed=seed)
    log = result.log
    R0 = log["rotation"][0]
    # Rotation of the pad relative to its start, about the start's sensor axes (deg).
    relative = Rotation.from_matrix(np.einsum("ji,njk->nik", R0, log["rotation"])).as_rotvec(degrees=True)
    return {"report": result.report, "t": log["t"], "cop_y_px": log["error_cop_y_px"],
            "cop_x_px": log["error_cop_x_px"], "rot_x_deg": relative[:, 0], "rot_y_deg": relative[:, 1],
            "pressure": log["pressure_pa"] / defaults.TARGET_PRESSURE_PA}


def plot_roll(roll: dict, out: Path) -> Path:
    """Fig. 11 style: COP error, rolling angle and pressure against time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(7, 6.5), sharex=True, constrained_layout=True)
    axes[0].plot(roll["t"], roll["cop_y_px"], lw=1, label="y")
    axes[0].plot(roll["t"], roll["cop_x_px"], lw=1, label="x")
    axes[0].set_ylabel("COP error (px)")
    axes[0].legend(fontsize=8)
    axes[1].plot(roll["t"], roll["rot_x_deg"], lw=1.2, color="C3", label="about sensor x")
    axes[1].plot(roll["t"], roll["rot_y_deg"], lw=1, color="C4", label="about sensor y")
    axes[1].set_ylabel("pad rotation (deg)")
    axes[1].legend(fontsize=8)
    axes[2].plot(roll["t"], roll["pressure"], lw=1, color="C2")
    axes[2].set_ylabel("pressure (units of 2 kPa)")
    axes[2].set_xlabel("t (s)")
    for ax in axes:
        ax.axvline(4.0, color="0.5", ls="--", lw=0.8)
        ax.grid(alpha=0.3)
    axes[0].set_title("Rolling: the ball is displaced at 4 s (dashed), cf. Fig. 11", fontsize=10)
    path = out / "fig11_roll.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_figures(results: dict, out: Path) -> list[Path]:
    """Figures in the style of the paper's Figs. 8–10 (error against time, first trial)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    target = defaults.TARGET_PRESSURE_PA
    paths = []
    fig, ax = plt.subplots(figsize=(7, 3.6), constrained_layout=True)
    for key, colour in (("force_ball", "C0"), ("force_pen", "C1"), ("force_box", "C2")):
        if key in results:
            log = results[key]["log"]
            ax.plot(log["t"], log["pressure_pa"] / target, color=colour, lw=1, label=results[key]["label"])
    ax.axhline(1.0, color="k", lw=0.8, label="desired value")
    ax.axhspan(0.96, 1.04, color="0.85", label="sensor noise ±0.04")
    ax.set_xlim(0, 4)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("pressure (units of 2 kPa)")
    ax.set_title("Normal force control on objects of different stiffness (cf. Fig. 8)", fontsize=10)
    ax.legend(fontsize=8)
    paths.append(out / "fig8_force.png")
    fig.savefig(paths[-1], dpi=110)
    plt.close(fig)
    for key, name in (("position", "fig9_position.png"), ("hybrid", "fig10_hybrid.png")):
        if key not in results:
            continue
        log = results[key]["log"]
        fig, (a, b) = plt.subplots(2, 1, figsize=(7, 5), sharex=True, constrained_layout=True)
        a.plot(log["t"], log["error_cop_x_px"], lw=1, label="x axis")
        a.plot(log["t"], log["error_cop_y_px"], lw=1, label="y axis")
        a.set_ylabel("pixel error")
        a.legend(fontsize=8)
        b.plot(log["t"], log["pressure_pa"] / target, lw=1, color="C3")
        b.set_ylabel("pressure (units of 2 kPa)")
        b.set_xlabel("t (s)")
        b.set_xlim(0, 4)
        a.set_title(f"{results[key]['label']} (cf. Fig. {9 if key == 'position' else 10})", fontsize=10)
        paths.append(out / name)
        fig.savefig(paths[-1], dpi=110)
        plt.close(fig)
    return paths


def write_paper(results: dict, out: Path) -> list[Path]:
    """tables.md, tables.json and the figures into ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    (out / "tables.md").write_text(format_tables(results))
    slim = {k: {kk: vv for kk, vv in v.items() if kk != "log"} for k, v in results.items()}
    (out / "tables.json").write_text(json.dumps(slim, indent=2) + "\n")
    return [out / "tables.md", out / "tables.json", *plot_figures(results, out)]
