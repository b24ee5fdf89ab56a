"""Where to sweep with the pad's border: the band the table leaves at the foot of a plane face,
and the sides of a valley narrower than the pad.

A pad lying flat on a face that goes on down to the table stops with its lowest border a few
millimetres above the table, and the band below stays untouched (the frontier planner estimates
it, :func:`~tactile_bt.contacts.untouched.untouched_below`). A level pad held just
above the table reaches it: slid towards the face, its border touches the face at the pad's own
height, all four corners equally high. :func:`foot_runs` turns the frontier cells on such faces
(their centres, heights and mean normals, from the planner) into straight runs of the face's
foot: the outward horizontal direction of the face, the direction along its foot, where the foot
lies at the sweeping height and how far it runs.

A flat pad bridges a hollow narrower than itself and leaves its sides untouched
(:meth:`~tactile_bt.contacts.frontier_map.FrontierMap.valleys`). Tilted about the hollow's
longer axis, its body over the touched rim and its border row in the hollow, the pad touches
the side with its border alone. :func:`valley_sides` gives these sweeps, one per side of each
hollow.

:class:`SweepPlan` remembers the sweeps done, so that each is made once.

Layer: contacts.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["SweepPlan", "foot_runs", "to_corners", "valley_sides", "END_INSIDE_M"]

#: A sweep along a run starts and ends with the middle of the pad's border this far (m) inside
#: the run's ends (or at its middle, on a run shorter than the border): the border passes over
#: the run's ends and beyond.
END_INSIDE_M = 0.01

#: Cells whose outward directions differ by at most this much (rad) belong to one face.
_SAME_FACE_RAD = math.radians(10.0)
#: ... and whose foot lines lie at most this far apart (m) across.
_SAME_LINE_M = 0.006
#: A run of foot is split where its cells leave a gap longer than this (m).
_GAP_M = 0.02
#: A run needs this many cells and this length (m): fewer are a corner's or a ridge's.
_LEAST_CELLS = 5
_LEAST_LENGTH_M = 0.01
#: A hole whose spread across is at least this share of its spread along is round: swept along
#: both of its axes.
_ROUND = 0.5
#: A face tilted less than this (rad) from the level has no foot to sweep.
_LEAST_TILT_RAD = math.radians(5.0)


def foot_runs(xy: np.ndarray, z: np.ndarray, normals: np.ndarray, foot_z: float) -> list[dict]:
    """Straight runs of foot below frontier cells on plane faces.

    Parameters
    ----------
    xy, z : (k, 2) and (k,) arrays
        World xy and height of the frontier cells (m).
    normals : (k, 3) array
        Their mean outward normals (unit, world).
    foot_z : float
        World height (m) at which the foot is followed (the table's plus the sweeping height).

    Returns
    -------
    list of dict
        One per run of at least five cells and 10 mm (fewer are a corner's), longest first:
        ``kind`` ("foot"), ``out`` (unit world xy, away from the object), ``along`` (unit world
        xy along the foot), ``normal`` (the face's mean outward normal), ``start``
        (world xy, m, of the foot at ``foot_z`` at the run's first end), ``length_m``,
        ``centre`` (world xy of its middle), ``band_top_z`` (world height, m, of the band
        left above the foot: the 90th percentile of the run's frontier cells' heights) and
        ``cells`` (the indices of its frontier cells in the arguments).
    """
    xy, z, normals = (np.asarray(a, dtype=float) for a in (xy, z, normals))
    horizontal = np.linalg.norm(normals[:, :2], axis=1) if len(normals) else np.zeros(0)
    usable = np.isfinite(horizontal) & (horizontal > math.sin(_LEAST_TILT_RAD)) & np.isfinite(z)
    given = np.flatnonzero(usable)
    xy, z, normals, horizontal = xy[usable], z[usable], normals[usable], horizontal[usable]
    if not len(xy):
        return []
    out = normals[:, :2] / horizontal[:, None]
    run_down = np.maximum(z - foot_z, 0.0) * normals[:, 2] / horizontal  # (z - foot) / tan(tilt)
    foot = xy + out * run_down[:, None]
    free = np.ones(len(xy), dtype=bool)
    runs: list[dict] = []
    while np.any(free):
        seed = int(np.flatnonzero(free)[0])
        o = out[seed]
        member = free & (out @ o >= math.cos(_SAME_FACE_RAD)) & (np.abs((foot - foot[seed]) @ o) <= _SAME_LINE_M)
        free &= ~member
        idx = np.flatnonzero(member)
        o = out[idx].mean(axis=0)
        o /= np.linalg.norm(o)
        along = np.array([-o[1], o[0]])
        s = foot[idx] @ along
        order = np.argsort(s)
        idx, s = idx[order], s[order]
        offset = float(np.mean(foot[idx] @ o))
        normal = normals[idx].mean(axis=0)
        normal /= np.linalg.norm(normal)
        cuts = np.flatnonzero(np.diff(s) > _GAP_M) + 1
        for part in np.split(np.arange(len(idx)), cuts):
            s0, s1 = float(s[part[0]]), float(s[part[-1]])
            if len(part) < _LEAST_CELLS or s1 - s0 < _LEAST_LENGTH_M:
                continue
            start = o * offset + along * s0
            runs.append({"kind": "foot", "out": o.copy(), "along": along.copy(), "normal": normal.copy(), "start": start,
                         "length_m": s1 - s0, "centre": start + along * (s1 - s0) / 2,
                         "band_top_z": float(np.percentile(z[idx[part]], 90)), "cells": given[idx[part]]})
    runs.sort(key=lambda r: -r["length_m"])
    return runs


def to_corners(runs: list[dict], most_m: float, others: list[dict] = ()) -> list[dict]:
    """The runs of foot (:func:`foot_runs`), each end carried on along its foot line to the
    corner where it meets another face's foot, where that corner lies at most ``most_m`` (m)
    beyond the ends of both runs. The feet of ``others`` (runs swept before, whose frontier is
    gone) count as other faces' too.

    The frontier a run is made of stops short of a face's ends: near a ridge the cells' mean
    normals mix the two faces', and the touched area rounds off towards the corner between two
    feet, where the pad lying on either face cannot go. The corner is where the two feet's lines
    cross. Beyond it along the line, on a base that is convex there, no object lies under the
    border, so a sweep may run on to it.

    Returns
    -------
    list of dict
        The runs in the same order; where an end moved, a copy with ``start``, ``length_m`` and
        ``centre`` updated (``cells`` as they were).
    """
    out = []
    for run in runs:
        length = float(run["length_m"])
        start, along = np.asarray(run["start"], dtype=float), np.asarray(run["along"], dtype=float)
        before, after = [], []  # corners beyond the run's start and its end, along it from its start (m)
        for other in [*runs, *others]:
            if other is run or float(np.asarray(other["out"]) @ np.asarray(run["out"])) >= math.cos(_SAME_FACE_RAD):
                continue
            o_start, o_along = np.asarray(other["start"], dtype=float), np.asarray(other["along"], dtype=float)
            cross = float(along[0] * o_along[1] - along[1] * o_along[0])
            if abs(cross) < 1e-9:  # parallel feet meet nowhere
                continue
            d = o_start - start
            s = float(d[0] * o_along[1] - d[1] * o_along[0]) / cross  # the corner, along this run
            t = float(d[0] * along[1] - d[1] * along[0]) / cross  # and along the other
            if not -_SAME_LINE_M <= max(-t, t - float(other["length_m"])) <= most_m:
                continue  # not at or beyond an end of the other, or too far beyond it
            if -most_m <= s < 0.0:
                before.append(s)
            elif length < s <= length + most_m:
                after.append(s)
        s0, s1 = max(before, default=0.0), min(after, default=length)  # the nearest corner beyond each end
        if s0 == 0.0 and s1 == length:
            out.append(run)
            continue
        moved = dict(run, start=start + along * s0, length_m=s1 - s0)
        moved["centre"] = moved["start"] + along * (s1 - s0) / 2
        out.append(moved)
    return out


def valley_sides(m, mask: np.ndarray, step_m: float = 0.005) -> list[dict]:
    """Sweeps of the sides of the valleys in ``mask`` (the untouched cells of holes narrower
    than the pad, :meth:`~tactile_bt.contacts.frontier_map.FrontierMap.valleys`), one per side
    of each hole along its longer axis: a pad tilted about that axis, its body over the touched
    rim and its border in the hole, sweeps along the hole in passes ``step_m`` apart from the
    hole's edge to its middle.

    Returns
    -------
    list of dict
        ``kind`` ("valley"), ``out`` (unit world xy from the hole towards this side), ``along``,
        ``start`` (world xy of the border's line at the hole's edge, at its first end),
        ``length_m``, ``width_m`` (how far inwards the passes go), ``step_m``, ``rim_z`` (the
        rim's height there, m), ``rim_rise`` (the rim's slope rising away from the hole, from its
        mean normal: where the sweeping pad starts to tilt from), ``normal`` (the rim's mean
        outward normal), ``centre`` (world xy).
    """
    from scipy import ndimage

    holes, count = ndimage.label(mask)
    sides: list[dict] = []
    touched = np.isfinite(m.z_max)
    for k in range(1, count + 1):
        rows, cols = np.nonzero(holes == k)
        if len(rows) < 4 * _LEAST_CELLS:
            continue
        xy = m.centre_of(rows, cols)
        mid = xy.mean(axis=0)
        _, spread, axes = np.linalg.svd(xy - mid, full_matrices=False)
        # a long hole is swept along its axis; a round one along both
        for along in axes[:2] if spread[1] > _ROUND * spread[0] else axes[:1]:
            sides.extend(_sides_along(m, touched, xy, mid, along, step_m))
    return sides


def _sides_along(m, touched: np.ndarray, xy: np.ndarray, mid: np.ndarray, along: np.ndarray,
                 step_m: float) -> list[dict]:
    """The two sides of the hole of cells ``xy`` (middle ``mid``) swept along ``along``."""
    sides: list[dict] = []
    across = np.array([-along[1], along[0]])
    s, c = (xy - mid) @ along, (xy - mid) @ across
    width = float(c.max() - c.min()) + m.cell_m
    for sign in (1.0, -1.0):
        out = across * sign
        edge = float(max(sign * c)) + m.cell_m / 2  # the hole's border on this side, from mid
        # the touched cells just outside that border: the rim
        probe = mid + out * (edge + m.cell_m) + along * np.linspace(s.min(), s.max(), 12)[:, None]
        rc = m.cell_of(probe)
        inside = np.all((rc >= 0) & (rc < m.n), axis=1)
        rc = rc[inside]
        rim = touched[rc[:, 0], rc[:, 1]]
        if not np.any(rim):
            continue
        rc = rc[rim]
        normal = np.nanmean(m.mean_normal(rc[:, 0], rc[:, 1]), axis=0)
        start = mid + out * (edge - 0.001) + along * float(s.min())
        length = float(s.max() - s.min())
        rim_z = float(np.max(m.z_max[rc[:, 0], rc[:, 1]]))
        normal /= np.linalg.norm(normal)
        rise = -float(normal[:2] @ out) / max(float(normal[2]), 0.1)  # the rim's rise away from the hole
        sides.append({"kind": "valley", "out": out.copy(), "along": along.copy(), "start": start,
                      "length_m": length, "width_m": width / 2 + step_m, "step_m": step_m,
                      "rim_z": rim_z, "rim_rise": rise, "normal": normal,
                      "centre": start + along * length / 2})
    return sides


class SweepPlan:
    """The border sweeps of one map, so that each is made once.

    A valley's side whose middle lies within ``radius_m`` of a swept one's, facing the same
    way, is not swept again. A run of foot is not swept again where an earlier sweep of the
    same face's foot (facing the same way, on the same line) covered it: the run itself and
    ``reach_m`` beyond each of its ends, which the pad's border passes over; a run of the same
    face that reaches more than ``new_m`` beyond that (the frontier left along a foot grows as
    the scan goes on) is swept. ``most`` sweeps at most.
    """

    def __init__(self, radius_m: float = 0.03, most: int = 12, reach_m: float = 0.0, new_m: float = 0.005) -> None:
        self.radius_m = float(radius_m)
        self.most = int(most)
        self.reach_m = float(reach_m)
        self.new_m = float(new_m)
        self.swept: list[dict] = []

    def choose(self, candidates: list[dict], from_xy: np.ndarray, take: bool = True) -> dict | None:
        """The candidate (:func:`foot_runs`, :func:`valley_sides`) nearest to ``from_xy``
        (world, m) not swept before; None when none is left or ``most`` have been swept. With
        ``take`` False it is not counted as swept: whether a sweep is left to make."""
        if len(self.swept) >= self.most:
            return None
        fresh = [r for r in candidates if not any(self._covers(d, r) for d in self.swept)]
        if not fresh:
            return None
        run = min(fresh, key=lambda r: float(np.linalg.norm(r["centre"] - np.asarray(from_xy)[:2])))
        if take:
            self.swept.append(run)
        return run

    def _covers(self, done: dict, run: dict) -> bool:
        """Whether the sweep ``done`` covered the candidate ``run`` (see the class docstring)."""
        if run["out"] @ done["out"] < math.cos(_SAME_FACE_RAD) or run.get("kind") != done.get("kind"):
            return False
        if run.get("kind") != "foot":
            return bool(np.linalg.norm(run["centre"] - done["centre"]) <= self.radius_m)
        start = np.asarray(run["start"]) - np.asarray(done["start"])
        if abs(float(start @ done["out"])) > _SAME_LINE_M:
            return False
        ends = float(start @ done["along"]) + np.array([0.0, 1.0]) * run["length_m"] * float(run["along"] @ done["along"])
        margin = self.reach_m + self.new_m
        return bool(ends.min() >= -margin and ends.max() <= done["length_m"] + margin)
