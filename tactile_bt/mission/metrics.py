"""Accuracy metrics of a mission: the columns of the paper's Tables I–III and the path error of
cable following.

Definitions (applied to the error ``e(t) = measured − target`` of a controlled feature, as the
controller sees it, i.e. after the paper's 10-sample smoothing for pressure and orientation):

* ``t0``: the first cycle in which the controller of the feature ran (after the approach);
* ``response_time_s``: time from ``t0`` until ``|e|`` enters the feature's band and stays inside
  it for a dwell time (bands and dwell in :mod:`tactile_bt.defaults`);
* ``steady_state_error`` and ``std``: mean and standard deviation of ``e`` from the response time
  to the end of the window (``t0`` + 20 s, or the end of the run), the paper's definition.

Force figures (:func:`force_figures`, the report's ``force``): after the approach, i.e. in the
cycles where a leaf held a pressure target (its logged ``error_pressure_pa`` is finite; the target
of a cycle is the smoothed pressure minus that error, so an adapted target counts as adapted),
the longest run of the smoothed pressure above ``defaults.FORCE_FIGURE_PRESSURE_FACTOR`` times
the target, the largest contact force, and the chatter of the commanded twist (sign changes per
second of a row between consecutive cycles whose jump exceeds a share of the row's twist limit).

Layer: mission.
"""

from __future__ import annotations

import numpy as np

from tactile_bt import defaults

__all__ = ["response_time", "feature_metrics", "controlled_feature_metrics", "path_error", "force_figures",
           "chatter_rate", "longest_run"]


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


def longest_run(t: np.ndarray, flag: np.ndarray) -> float:
    """Longest time (s) ``flag`` stays true without a break: from the first to one period past
    the last cycle of a run (one cycle counts as one period)."""
    flag = np.asarray(flag, dtype=bool)
    if not flag.any():
        return 0.0
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    edges = np.diff(np.concatenate(([0], flag.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    return float(max(t[e - 1] - t[s] + dt for s, e in zip(starts, ends)))


def chatter_rate(t: np.ndarray, twist: np.ndarray, jump_share: float = defaults.CHATTER_FIGURE_JUMP_SHARE,
                 linear_limit: float = defaults.TWIST_LINEAR_LIMIT_MPS,
                 angular_limit: float = defaults.TWIST_ANGULAR_LIMIT_RPS) -> list[float]:
    """Sign changes per second of each row of a commanded twist ``(n, 6)`` (m/s, rad/s) whose
    jump between consecutive cycles exceeds ``jump_share`` of the row's limit: a row that
    switches from one large value to the opposite one, tick after tick."""
    twist = np.asarray(twist, dtype=float)
    if len(t) < 2:
        return [0.0] * 6
    limits = np.array([linear_limit] * 3 + [angular_limit] * 3)
    a, b = twist[:-1], twist[1:]
    flips = (a * b < 0) & (np.abs(b - a) >= jump_share * limits)
    span = float(t[-1] - t[0]) or 1.0
    return [float(n) / span for n in flips.sum(axis=0)]


def force_figures(log: dict, factor: float = defaults.FORCE_FIGURE_PRESSURE_FACTOR,
                  max_over_s: float = defaults.FORCE_FIGURE_MAX_OVER_S,
                  force_cap_n: float = defaults.SUPERVISOR_FORCE_CAP_N) -> dict:
    """How hard a mission pressed after its approach (module docstring), from its log (``t``,
    ``pressure_pa``, ``error_pressure_pa``, ``force_n``, ``twist_s``).

    Returns
    -------
    dict
        ``approach_end_s`` (the first cycle a target was held, s; None: never), ``held_s`` (time a
        pressure target was held, s), ``target_min_pa`` / ``target_max_pa``
        (its range, Pa), ``over_s`` (time above ``factor`` × target, s), ``longest_over_s``
        (its longest run, s), ``over_share`` (``over_s / held_s``), ``peak_ratio`` (largest
        pressure / target), ``peak_force_n`` (largest force after the approach, N),
        ``chatter_per_s`` (:func:`chatter_rate` per twist row after the approach), and ``ok``:
        ``longest_over_s <= max_over_s`` and ``peak_force_n <= force_cap_n``.
    """
    t = np.asarray(log["t"], dtype=float)
    error = np.asarray(log["error_pressure_pa"], dtype=float)
    held = np.isfinite(error)
    empty = {"approach_end_s": None, "held_s": 0.0, "target_min_pa": None, "target_max_pa": None, "over_s": 0.0,
             "longest_over_s": 0.0,
             "over_share": 0.0, "peak_ratio": None, "peak_force_n": 0.0, "chatter_per_s": [0.0] * 6, "ok": True}
    if not held.any():
        empty["peak_force_n"] = float(np.nanmax(np.asarray(log["force_n"], dtype=float), initial=0.0))
        empty["ok"] = empty["peak_force_n"] <= force_cap_n
        return empty
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    pressure = np.asarray(log["pressure_pa"], dtype=float)
    target = pressure - error  # the logged error is measured - target
    over = held & (pressure > factor * np.where(held, target, np.inf))
    after = t >= t[np.argmax(held)]
    force = np.nan_to_num(np.asarray(log["force_n"], dtype=float)[after])
    longest = longest_run(t, over)
    peak_force = float(force.max()) if len(force) else 0.0
    return {
        "approach_end_s": float(t[np.argmax(held)]),
        "held_s": float(held.sum() * dt),
        "target_min_pa": float(np.min(target[held])),
        "target_max_pa": float(np.max(target[held])),
        "over_s": float(over.sum() * dt),
        "longest_over_s": longest,
        "over_share": float(over.sum() / held.sum()),
        "peak_ratio": float(np.max(pressure[held] / target[held])),
        "peak_force_n": peak_force,
        "chatter_per_s": chatter_rate(t[after], np.asarray(log["twist_s"], dtype=float)[after]),
        "ok": bool(longest <= max_over_s and peak_force <= force_cap_n),
    }
