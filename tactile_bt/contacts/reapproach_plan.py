"""Where to approach a touched surface anew: the frontier that sliding could not cross.

When no frontier is left that a sliding pad can reach, but some of the frontier left has no
explaining reason (:data:`~tactile_bt.contacts.frontier_map.EXPLAINING`: the pad stalled at a
ridge, in a valley, ...), :class:`ReapproachPlan` chooses the nearest such frontier cell not
tried before and a probe beyond it: the point ``beyond_m`` past the cell, outwards, at the
cell's highest sample, and the estimated outward normal there (the cell's mean normal, tilted
at most ``max_tilt_rad`` from the vertical). It applies what the re-approach found: the
surface (the cells around are unblocked, to be slid over again), the table or the arm's reach
(the cells around are closed for that reason, which explains them), or nothing.

Layer: contacts.
"""

from __future__ import annotations

import math

import numpy as np

from tactile_bt.contacts.frontier_map import EXPLAINING, GAP, FrontierMap

__all__ = ["ReapproachPlan", "clamp_tilt"]


def clamp_tilt(normal: np.ndarray, max_tilt_rad: float) -> np.ndarray:
    """``normal`` (unit, world) turned towards +z until it is tilted at most ``max_tilt_rad``."""
    n = np.asarray(normal, dtype=float)
    horizontal = math.hypot(n[0], n[1])
    if math.atan2(horizontal, n[2]) <= max_tilt_rad or horizontal < 1e-12:
        return n
    h = n[:2] / horizontal
    return np.array([h[0] * math.sin(max_tilt_rad), h[1] * math.sin(max_tilt_rad), math.cos(max_tilt_rad)])


class ReapproachPlan:
    """The re-approaches of one map: targets chosen, the places tried (``radius_m`` around
    each is not tried again) and the results applied."""

    def __init__(self, beyond_m: float = 0.02, radius_m: float = 0.02) -> None:
        self.beyond_m = float(beyond_m)
        self.radius_m = float(radius_m)
        #: World xy (m) of the frontier cells re-approached so far.
        self.tried: list[np.ndarray] = []

    def choose(self, m: FrontierMap, rows: np.ndarray, cols: np.ndarray, out: np.ndarray, reason: np.ndarray,
               from_xy: np.ndarray, max_tilt_rad: float) -> dict | None:
        """The re-approach of the unexplained frontier cell nearest to ``from_xy`` (world, m)
        and not within ``radius_m`` of one tried before, from :meth:`FrontierMap.classify`'s
        output; None when there is none. ``{"frontier_xy", "probe": (point, normal),
        "top_z"}`` (world, m)."""
        keep = np.array([r not in EXPLAINING and r != GAP for r in reason], dtype=bool)
        if not np.any(keep):
            return None
        xy = m.centre_of(rows[keep], cols[keep])
        ok = np.ones(len(xy), dtype=bool)
        for t in self.tried:
            ok &= np.linalg.norm(xy - t, axis=1) > self.radius_m
        if not np.any(ok):
            return None
        idx = np.flatnonzero(keep)[ok]
        xy = xy[ok]
        k = int(np.argmin(np.linalg.norm(xy - np.asarray(from_xy)[:2], axis=1)))
        r, c, o = int(rows[idx[k]]), int(cols[idx[k]]), out[idx[k]]
        normal = clamp_tilt(m.normal_at(r, c), max_tilt_rad)
        point = np.array([xy[k][0] + o[0] * self.beyond_m, xy[k][1] + o[1] * self.beyond_m, m.z_max[r, c]])
        self.tried.append(xy[k].copy())
        touched = np.isfinite(m.z_max)
        return {"frontier_xy": xy[k].copy(), "probe": (point, normal), "top_z": float(m.z_max[touched].max())}

    def apply(self, m: FrontierMap, job: dict) -> str:
        """Apply the ``result`` of a carried-out re-approach to the map; returns it."""
        result = str(job.get("result", ""))
        if result == "surface":
            m.unblock(job["frontier_xy"], self.radius_m)
        elif result:
            m.close(job["frontier_xy"], self.radius_m, result)
        return result
