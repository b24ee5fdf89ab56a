"""Where to approach a touched surface anew: the frontier that sliding could not cross.

When no frontier is left that a sliding pad can reach, but some of the frontier left has no
explaining reason (:data:`~tactile_bt.contacts.frontier_map.EXPLAINING`: the pad stalled at a
ridge, in a valley, ...), :class:`ReapproachPlan` chooses the nearest such frontier cell not
tried before and a probe beyond it: the point ``beyond_m`` past the cell, outwards, at the
cell's highest sample, and the estimated outward normal there (the cell's mean normal, tilted
at most ``max_tilt_rad`` from the vertical). It applies what the re-approach found: the
surface (the cells around are unblocked, to be slid over again), the table or the arm's reach
(the cells around are closed for that reason, which explains them), or nothing.

A probe that touched the surface on the near side of the frontier (the pad landed on what it
had touched before, as it does beyond an edge that drops away) found nothing beyond it. Then
the next re-approach is a *far probe* of the same frontier: a level pad lowered, down to the
table if need be, with its whole face beyond the frontier (its centre ``far_m`` past it). Where
it comes down to the table touching nothing, nothing within its footprint stands above the
table, and the frontier along the pad's width is closed as the table's. The strip between the
frontier and the pad's nearest border (3 mm at a corner, up to ``far_m`` less half the pad's
width at an edge) stays unprobed below the frontier's height.

Frontier that a re-approach near it (within ``radius_m``) did not explain, and that is still
unexplained when nothing else is left, gets a far probe of its own, not within ``radius_m`` of
one before: sliding and approaching along its normal have both been tried there, and the far probe
tells whether anything stands beyond it at all.

Layer: contacts.
"""

from __future__ import annotations

import math

import numpy as np

from tactile_bt.contacts.frontier_map import FrontierMap, unexplained

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
        #: The far probe to make next (see the module docstring), if any.
        self.far: dict | None = None
        #: World xy (m) of the frontier cells far-probed so far.
        self.far_probed: list[np.ndarray] = []

    def choose(self, m: FrontierMap, rows: np.ndarray, cols: np.ndarray, out: np.ndarray, reason: np.ndarray,
               from_xy: np.ndarray, max_tilt_rad: float, reasons: frozenset | None = None,
               far_m: float = 0.0, table_z_m: float = math.nan) -> dict | None:
        """The re-approach of the unexplained frontier cell (or, given ``reasons``, of a cell
        with one of them) nearest to ``from_xy`` (world, m) and not within ``radius_m`` of one
        tried before, from :meth:`FrontierMap.classify`'s output; None when there is none.
        ``{"frontier_xy", "out", "probe": (point, normal), "top_z"}`` (world, m). A far probe
        pending (:meth:`apply`) comes first, while its frontier is still unexplained.

        Without ``reasons``, with ``far_m`` > 0 and the table's height ``table_z_m`` (world, m):
        when every unexplained cell lies within ``radius_m`` of one tried before, the far probe
        (centred ``far_m`` beyond it, see :meth:`apply`) of the nearest not within ``radius_m``
        of one far-probed before."""
        if reasons is None:
            keep = unexplained(reason)
        else:
            keep = np.isin(np.asarray(reason).astype(str), sorted(reasons))
        if self.far is not None:
            job, self.far = self.far, None
            near = np.linalg.norm(m.centre_of(rows, cols) - job["frontier_xy"], axis=1) <= m.cell_m
            if np.any(near & keep):
                return job
        if not np.any(keep):
            return None
        xy = m.centre_of(rows[keep], cols[keep])
        ok = self._away(xy, self.tried)
        if not np.any(ok):
            if reasons is not None or far_m <= 0 or not math.isfinite(table_z_m):
                return None
            ok = self._away(xy, self.far_probed)
            if not np.any(ok):
                return None
            job = self._nearest(m, rows, cols, out, np.flatnonzero(keep)[ok], xy[ok], from_xy, max_tilt_rad)
            self.far_probed.append(job["frontier_xy"].copy())
            return self._far_job(job, far_m, table_z_m)
        return self._nearest(m, rows, cols, out, np.flatnonzero(keep)[ok], xy[ok], from_xy, max_tilt_rad)

    def _away(self, xy: np.ndarray, places: list[np.ndarray]) -> np.ndarray:
        """``(k,)`` bool: which of the points ``xy`` ``(k, 2)`` lie farther than ``radius_m``
        from every one of ``places`` (world xy, m)."""
        ok = np.ones(len(xy), dtype=bool)
        for t in places:
            ok &= np.linalg.norm(xy - t, axis=1) > self.radius_m
        return ok

    def _nearest(self, m: FrontierMap, rows: np.ndarray, cols: np.ndarray, out: np.ndarray, idx: np.ndarray,
                 xy: np.ndarray, from_xy: np.ndarray, max_tilt_rad: float) -> dict:
        """The re-approach of the cell ``idx`` (into ``rows``, ...; its centre ``xy``) nearest
        to ``from_xy``, counted as tried."""
        k = int(np.argmin(np.linalg.norm(xy - np.asarray(from_xy)[:2], axis=1)))
        r, c, o = int(rows[idx[k]]), int(cols[idx[k]]), out[idx[k]]
        normal = clamp_tilt(m.normal_at(r, c), max_tilt_rad)
        point = np.array([xy[k][0] + o[0] * self.beyond_m, xy[k][1] + o[1] * self.beyond_m, m.z_max[r, c]])
        self.tried.append(xy[k].copy())
        touched = np.isfinite(m.z_max)
        return {"frontier_xy": xy[k].copy(), "out": np.asarray(o, dtype=float).copy(), "probe": (point, normal),
                "top_z": float(m.z_max[touched].max())}

    def apply(self, m: FrontierMap, job: dict, far_m: float = 0.0, table_z_m: float = math.nan,
              half_width_m: float = 0.0) -> str:
        """Apply the ``result`` of a carried-out re-approach to the map; returns it.

        With ``far_m`` > 0, a probe that touched the surface (``job["touched"]``, world, m) less
        than a cell beyond the frontier along ``job["out"]`` leaves the frontier as it was and
        plans a far probe of it, centred ``far_m`` beyond it, level, lowered down to the table
        at ``table_z_m`` (``"approach_m"``); the table it finds closes the frontier within
        ``half_width_m`` (the pad's half width) of the frontier cell."""
        result = str(job.get("result", ""))
        radius = self.radius_m
        if job.get("far"):
            radius = max(radius, half_width_m)
            self.far_probed.append(np.asarray(job["frontier_xy"], dtype=float).copy())
        elif result == "surface" and far_m > 0 and math.isfinite(table_z_m) and "touched" in job:
            beyond = float((np.asarray(job["touched"])[:2] - job["frontier_xy"]) @ job["out"])
            if beyond < m.cell_m:  # landed on the touched side: nothing found beyond
                self._plan_far(job, far_m, table_z_m)
                return "near side"
        if result == "surface":
            m.unblock(job["frontier_xy"], radius)
        elif result:
            m.close(job["frontier_xy"], radius, result)
        return result

    def _plan_far(self, job: dict, far_m: float, table_z_m: float) -> None:
        """Make the far probe of ``job``'s frontier the next re-approach (see :meth:`apply`)."""
        self.far = self._far_job(job, far_m, table_z_m)

    @staticmethod
    def _far_job(job: dict, far_m: float, table_z_m: float) -> dict:
        """The far probe of ``job``'s frontier (see :meth:`apply`)."""
        point = np.asarray(job["probe"][0], dtype=float)
        xy = job["frontier_xy"] + job["out"] * far_m
        return {"frontier_xy": job["frontier_xy"].copy(), "out": job["out"].copy(), "far": True,
                "probe": (np.array([xy[0], xy[1], point[2]]), np.array([0.0, 0.0, 1.0])),
                "approach_m": max(float(point[2] - table_z_m), 0.0), "top_z": job["top_z"]}
