"""``tree.png``: the status of every node of the tree against mission time, and how it ended.

One row per node in tree order (the root on top), its name indented by its depth; each run of
ticks with one status is a bar in that status's colour; a vertical line marks the end of the
mission with its status and reason, with a square per node in the status of the last tick (the
one that ended it, too short for a bar). Drawn from the log's ``node_names``, ``node_depth`` and
``node_status`` (:mod:`tactile_bt.mission.node_status`), so a replay, a sweep's kept run or an
old ``log.npz`` draws the same.

Layer: mission.
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np

from tactile_bt.mission.node_status import STATUS_NAMES

__all__ = ["STATUS_COLOURS", "status_runs", "plot_tree_status"]

#: Colour of each status, in the order of :data:`STATUS_NAMES` (invalid, running, success, failure).
STATUS_COLOURS = ("#e4e4e4", "#4c8fd6", "#4caf50", "#d9534f")


def status_runs(t: np.ndarray, codes: np.ndarray, dt: float) -> list[tuple[float, float, int]]:
    """Runs of equal codes of one node: ``(start_s, length_s, code)``; each tick lasts ``dt`` (s)."""
    if len(codes) == 0:
        return []
    starts = np.flatnonzero(np.diff(codes.astype(np.int16), prepend=-1))
    ends = np.append(starts[1:], len(codes))
    return [(float(t[a]), float(t[b - 1] - t[a] + dt), int(codes[a])) for a, b in zip(starts, ends)]


def _label(path: str, depth: int) -> str:
    return "    " * int(depth) + path.rsplit("/", 1)[-1] if depth else path


def plot_tree_status(log: dict, status: str = "", reason: str = "", title: str = "",
                     path: str | Path | None = None):
    """Draw node status against mission time (the figure; saved to ``path`` when given).

    Parameters
    ----------
    log : dict of arrays
        A mission's log with ``t`` (s), ``node_names``, ``node_depth`` and ``node_status``.
    status, reason : str
        How the mission ended, written at the end marker.
    title : str
        Figure title.
    path : path, optional
        Write the PNG here (headless).

    Raises
    ------
    KeyError
        When the log holds no node status (a mission run with ``node_status=False``).
    """
    import matplotlib

    if path is not None:
        matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    t = np.asarray(log["t"], float)
    names = [str(n) for n in log["node_names"]]
    depth = np.asarray(log.get("node_depth", [n.count("/") for n in names]))
    codes = np.asarray(log["node_status"])
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.004
    end = float(t[-1] + dt) if len(t) else 0.0
    height = 1.6 + 0.28 * len(names)
    fig, ax = plt.subplots(figsize=(10, height), constrained_layout=True)
    for row in range(len(names)):
        runs = status_runs(t, codes[:, row], dt)
        for code in range(len(STATUS_NAMES)):
            bars = [(a, w) for a, w, c in runs if c == code]
            if bars:
                ax.broken_barh(bars, (row - 0.4, 0.8), facecolors=STATUS_COLOURS[code], edgecolor="none")
    ax.set_yticks(range(len(names)), [_label(n, d) for n, d in zip(names, depth)], fontsize=8,
                  fontfamily="monospace")
    for label in ax.get_yticklabels():
        label.set_horizontalalignment("left")
    width = max((len(lab.get_text()) for lab in ax.get_yticklabels()), default=0)
    ax.tick_params(axis="y", pad=6 + 5.2 * width)
    ax.set_ylim(len(names) - 0.5, -0.5)
    ax.set_xlim(0.0, max(end, dt) * 1.015)
    ax.set_xlabel("mission time (s)")
    ax.grid(axis="x", alpha=0.3)
    ending = f"{status}: {reason}" if reason else status
    if ending:
        ax.axvline(end, color="k", lw=1.2)
        if len(codes):  # the last tick's statuses (the one that ended the mission), beside the line
            ax.scatter(np.full(len(names), end), np.arange(len(names)), marker="s", s=30, zorder=3,
                       c=[STATUS_COLOURS[c] for c in codes[-1]], edgecolors="k", linewidths=0.5, clip_on=False)
        ax.text(end, -0.5, " " + "\n ".join(textwrap.wrap(ending, 60)), ha="right", va="bottom", fontsize=8,
                clip_on=False)
    handles = [Patch(color=c, label=n) for n, c in zip(STATUS_NAMES, STATUS_COLOURS)]
    fig.legend(handles=handles, loc="outside lower center", ncol=4, fontsize=8, frameon=False)
    if title:
        fig.suptitle(title, fontsize=10)
    if path is not None:
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return fig
