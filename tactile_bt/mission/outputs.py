"""Mission outputs: report.json, log.npz, errors.png, tree.png and contacts.ply; for a scan (a mission
whose tree or run reconstructs a surface) also surface.ply and render.png.

Layer: mission.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np

from tactile_bt.contacts.ply import write_ply
from tactile_bt.arguments import check_output_dir
from tactile_bt import defaults

__all__ = ["OUTPUT_FILES", "prepare_output_dir", "present_outputs", "plot_errors", "write_outputs"]

#: Every file a mission may write into its output directory.
OUTPUT_FILES = ("report.json", "log.npz", "errors.png", "tree.png", "contacts.ply", "surface.ply", "render.png")


def prepare_output_dir(out: str | Path) -> Path:
    """Make ``out`` ready for a mission's outputs before the mission starts.

    Creates the directory (and its parents) and removes the files an earlier mission left
    there (:data:`OUTPUT_FILES` only; other files are kept), so the directory never mixes two
    runs. Raises :class:`OutputPathError` naming the path when it is a file or lies under one,
    or cannot be created.
    """
    out = check_output_dir(out)
    for name in OUTPUT_FILES:
        stale = out / name
        if stale.is_file() or stale.is_symlink():
            stale.unlink()
    return out


def present_outputs(out: str | Path) -> tuple[str, ...]:
    """The names of the :data:`OUTPUT_FILES` that are in ``out`` now, in their order."""
    return tuple(name for name in OUTPUT_FILES if (Path(out) / name).is_file())


def _jsonable(value):
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (np.floating, float)):
        v = float(value)
        return v if math.isfinite(v) else None
    if isinstance(value, np.integer):
        return int(value)
    return value


#: Share of the cycles (after its first value) in which a feature was undefined above which its
#: panel says so: the trace alone would look like an empty panel.
_UNDEFINED_NOTE_SHARE = 0.5


def _feature_panel(ax, t: np.ndarray, errors: list, measured: list, name: str, unit: str,
                   why_undefined: str = "") -> None:
    """One panel of :func:`plot_errors`: the errors of a feature's components (``(values,
    colour, label, line style)``) when a leaf controlled it, else its measured values; a note
    when the feature was undefined (NaN) in most cycles, or never measured."""
    controlled = any(np.isfinite(values).any() for values, *_ in errors)
    shown = errors if controlled else measured
    for values, colour, label, style in shown:
        ax.plot(t, values, color=colour, label=label, **{"lw": 1.0, **style})
    ax.set_ylabel(f"{name} error ({unit})" if controlled else f"{name} ({unit})")
    defined = np.zeros(len(t), bool)
    for values, *_ in shown:
        defined |= np.isfinite(values)
    note = ""
    if not defined.any():
        note = f"{name}: never measured{why_undefined}"
    else:
        if not controlled:
            ax.set_title(f"{name}: measured (no leaf controlled it)", fontsize=8, loc="left")
        undefined = 1.0 - float(np.mean(defined[int(np.argmax(defined)):]))
        if undefined > _UNDEFINED_NOTE_SHARE:
            note = f"{name} undefined in {undefined:.0%} of the cycles after its first value{why_undefined}"
    if note:
        ax.text(0.5, 0.5, note, transform=ax.transAxes, ha="center", va="center", color="0.3", fontsize=9,
                bbox={"facecolor": "white", "edgecolor": "0.8", "alpha": 0.9})
    if any(label for _, _, label, _ in shown):
        ax.legend(loc="upper right", fontsize=8)


def plot_errors(result, path: str | Path | None = None):
    """Feature errors against mission time, like the paper's Figs. 8–10 and 12b.

    Three panels: pressure error (in units of the target, the paper's p), COP error (px) and
    orientation error (deg). A feature no leaf controlled shows its measured values instead (a
    scan's orientation), or says it was never measured. The dashed line marks the end of the
    approach.
    """
    import matplotlib

    if path is not None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    log = result.log
    t = log["t"]
    fig, axes = plt.subplots(3, 1, figsize=(8, 7.5), sharex=True, constrained_layout=True)
    target = defaults.TARGET_PRESSURE_PA
    ax = axes[0]
    ax.plot(t, (log["pressure_raw_pa"] - target) / target, color="0.75", lw=0.6, label="raw")
    ax.plot(t, log["error_pressure_pa"] / target, color="C0", lw=1.2, label="smoothed (controlled)")
    ax.axhspan(-0.04, 0.04, color="C2", alpha=0.15, label="sensor noise level ±0.04")
    ax.set_ylabel("pressure error\n(units of target 2 kPa)")
    ax.legend(loc="upper right", fontsize=8)
    # x wide and underneath, y thin and dashed on top: where they coincide both stay visible
    cop = [("x", "C0", dict(lw=2.4)), ("y", "C1", dict(lw=1.0, ls="--"))]
    _feature_panel(axes[1], t, [(log[f"error_cop_{c}_px"], colour, c, style) for c, colour, style in cop],
                   [(log[f"cop_{c}_px"], colour, c, style) for c, colour, style in cop], "COP", "px")
    _feature_panel(axes[2], t, [(np.rad2deg(log["error_orientation_rad"]), "C3", None, {})],
                   [(np.rad2deg(log["orientation_rad"]), "C3", None, {})], "orientation", "deg",
                   why_undefined=" (no line contact: the imprint has no dominant axis)")
    axes[2].set_xlabel("mission time (s)")
    started = np.isfinite(log["error_pressure_pa"]) | np.isfinite(log["error_cop_x_px"])
    if started.any():
        t0 = t[int(np.argmax(started))]
        for ax in axes:
            ax.axvline(t0, color="0.4", ls="--", lw=0.8)
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.axhline(0.0, color="k", lw=0.5)
    report = result.summary
    fig.suptitle(f"{Path(report.tree).stem} on {Path(report.scene).stem or 'a live set-up'}: {report.status}"
                 + (f", seed {report.seed}" if report.seed is not None else ""),
                 fontsize=10)
    if path is not None:
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return fig


def write_outputs(result, out: Path, render: bool = True) -> None:
    """Write every output file of a mission into ``out``.

    A scan (the report has ``reconstruction``) also gets ``surface.ply`` (the reconstructed
    mesh, world frame, m) and, with ``render``, ``render.png`` (:func:`tactile_bt.mission.view.render_mission`,
    off screen).
    """
    out = prepare_output_dir(out)
    (out / "report.json").write_text(json.dumps(_jsonable(result.summary.to_dict()), indent=2) + "\n")
    np.savez_compressed(out / "log.npz", **result.log)
    if len(result.contact_data):
        write_ply(out / "contacts.ply", result.contact_data)
    plot_errors(result, out / "errors.png")
    if "node_status" in result.log:
        from tactile_bt.mission.tree_plot import plot_tree_status

        report = result.summary
        plot_tree_status(result.log, report.status, report.reason, path=out / "tree.png",
                         title=f"{Path(report.tree).stem}: node status"
                               + (f", seed {report.seed}" if report.seed is not None else ""))
    surface = getattr(result, "surface", None)
    if surface is not None and len(surface.faces):
        from tactile_bt.contacts.reconstruct import write_surface

        write_surface(out / "surface.ply", surface)
    if render and result.summary.reconstruction is not None:
        from tactile_bt.mission.view import render_mission

        try:
            render_mission(out, out / "render.png")
        except Exception as exc:  # no OpenGL here: every other output is written, say so
            warnings.warn(f"render.png not written: {type(exc).__name__}: {exc}", RuntimeWarning, stacklevel=2)
