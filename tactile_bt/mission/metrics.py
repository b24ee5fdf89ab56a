"""Accuracy metrics of a mission: the columns of the paper's Tables I–III and the path error of
cable following.

Definitions (applied to the error ``e(t) = measured − target`` of a controlled feature, as the
controller sees it, i.e. after the paper's 10-sample smoothing for pressure and orientation):

* ``t0``: the first cycle in which the controller of the feature ran (after the approach);
* ``response_time_s``: time from ``t0`` until ``|e|`` enters the feature's band and stays inside
  it for a dwell time (bands and dwell in :mod:`tactile_bt.defaults`);
* ``steady_state_error`` and ``std``: mean and standard deviation of ``e`` from the response time
  to the end of the window (``t0`` + 20 s, or the end of the run), the paper's definition.

Layer: mission.
"""

from __future__ import annotations

import numpy as np

from tactile_bt import defaults

__all__ = ["response_time", "feature_metrics", "controlled_feature_metrics", "path_error"]


def response_time(t: np.ndarray, error: np.ndarray, band: float, dwell: float = defaults.METRIC_DWELL_S) -> float:
    """Seconds from ``t[0]`` until ``|error|`` enters ``band`` and stays for ``dwell`` seconds.

    NaN samples count as outside the band. Returns NaN when the error never settles.
    """
    inside = np.abs(np.nan_to_num(error, nan=np.inf)) <= band
    if not inside.any():
        return float("nan")
    # Start index of each run of consecutive inside samples, and where the run ends.
    edges = np.diff(np.concatenate(([0], inside.astype(np.int8), [0])))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1)  # exclusive
    for s, e in zip(starts, ends):
        if t[e - 1] - t[s] >= dwell:
            return float(t[s] - t[0])
    return float("nan")


def feature_metrics(
    t: np.ndarray,
    error: np.ndarray,
    band: float,
    window_s: float = defaults.METRIC_WINDOW_S,
    dwell: float = defaults.METRIC_DWELL_S,
) -> dict | None:
    """Steady-state error, standard deviation and response time of one controlled feature.

    Returns None when the feature was never controlled (all NaN).
    """
    active = np.isfinite(error)
    if not active.any():
        return None
    i0 = int(np.argmax(active))
    t = t[i0:]
    error = error[i0:]
    in_window = t - t[0] <= window_s
    t, error = t[in_window], error[in_window]
    rt = response_time(t, error, band, dwell)
    settled = (t - t[0] >= rt) if np.isfinite(rt) else np.zeros(len(t), bool)
    tail = error[settled & np.isfinite(error)]
    return {
        "steady_state_error": float(np.mean(tail)) if len(tail) else float("nan"),
        "std": float(np.std(tail)) if len(tail) else float("nan"),
        "response_time_s": rt,
        "band": band,
        "start_s": float(t[0]),
        "window_s": float(t[-1] - t[0]),
    }


def controlled_feature_metrics(log: dict) -> dict:
    """:func:`feature_metrics` of every controlled feature in a mission log (``t`` and
    ``error_<name>`` series), keyed by name; features no controller ran are left out."""
    metrics = {}
    for name, band in defaults.METRIC_BANDS.items():
        m = feature_metrics(log["t"], log[f"error_{name}"], band)
        if m is not None:
            metrics[name] = m
    return metrics


def path_error(points_xy: np.ndarray, cable) -> dict:
    """Distance of tracked contact points (world, m) from a cable's true centreline (m).

    Distances are horizontal (in the table plane). ``followed_m`` is the arc length of the
    centreline between the first and last tracked point's nearest positions.
    """
    if len(points_xy) == 0:
        return {"mean": float("nan"), "max": float("nan"), "followed_m": 0.0, "cable_length_m": float(cable.length)}
    d = cable.distance_to_centreline(points_xy)
    s = cable.arc_position(points_xy)
    return {
        "mean": float(np.mean(d)),
        "max": float(np.max(d)),
        "p95": float(np.percentile(d, 95)),
        "followed_m": float(s.max() - s.min()),
        "cable_length_m": float(cable.length),
    }
