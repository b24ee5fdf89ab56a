"""Where to sweep the foot of a plane face with the pad's border: the band the table leaves.

A pad lying flat on a face that goes on down to the table stops with its lowest border a few
millimetres above the table, and the band below stays untouched (the frontier planner estimates
it, :meth:`~tactile_bt.contacts.frontier_map.FrontierMap.untouched_below`). A level pad held just
above the table reaches it: slid towards the face, its border touches the face at the pad's own
height, all four corners equally high. :class:`FootSweepPlan` turns the frontier cells on such
faces (their centres, heights and mean normals, from the planner) into straight runs of the
face's foot, each a *sweep*: the outward horizontal direction of the face, the direction along
its foot, where the foot lies at the sweeping height and how far it runs. It remembers the
sweeps done, so that each run of foot is swept once.

Layer: contacts.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["FootSweepPlan", "foot_runs"]

#: Cells whose outward directions differ by at most this much (rad) belong to one face.
_SAME_FACE_RAD = math.radians(10.0)
#: ... and whose foot lines lie at most this far apart (m) across.
_SAME_LINE_M = 0.006
#: A run of foot is split where its cells leave a gap longer than this (m).
_GAP_M = 0.02
#: A run needs this many cells and this length (m): fewer are a corner's or a ridge's.
_LEAST_CELLS = 5
_LEAST_LENGTH_M = 0.01
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
        One per run of at least five cells and 10 mm (fewer are a corner's), longest first: ``out`` (unit world xy, away from the object), ``along``
        (unit world xy along the foot), ``normal`` (the face's mean outward normal), ``start``
        (world xy, m, of the foot at ``foot_z`` at the run's first end), ``length_m`` and
        ``centre`` (world xy of its middle).
    """
    xy, z, normals = (np.asarray(a, dtype=float) for a in (xy, z, normals))
    horizontal = np.linalg.norm(normals[:, :2], axis=1) if len(normals) else np.zeros(0)
    usable = np.isfinite(horizontal) & (horizontal > math.sin(_LEAST_TILT_RAD)) & np.isfinite(z)
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
            runs.append({"out": o.copy(), "along": along.copy(), "normal": normal.copy(), "start": start,
                         "length_m": s1 - s0, "centre": start + along * (s1 - s0) / 2})
    runs.sort(key=lambda r: -r["length_m"])
    return runs


class FootSweepPlan:
    """The foot sweeps of one map: the runs swept so far (a run whose middle lies within
    ``radius_m`` of a swept one's and faces the same way is not swept again) and what each
    found."""

    def __init__(self, radius_m: float = 0.03, most: int = 12) -> None:
        self.radius_m = float(radius_m)
        self.most = int(most)
        self.swept: list[dict] = []
        self.results: list[str] = []

    def choose(self, xy: np.ndarray, z: np.ndarray, normals: np.ndarray, foot_z: float,
               from_xy: np.ndarray) -> dict | None:
        """The run of foot (:func:`foot_runs`) nearest to ``from_xy`` (world, m) not swept
        before; None when none is left or ``most`` have been swept."""
        if len(self.swept) >= self.most:
            return None
        fresh = [r for r in foot_runs(xy, z, normals, foot_z) if not any(
            np.linalg.norm(r["centre"] - d["centre"]) <= self.radius_m and r["out"] @ d["out"] >= math.cos(_SAME_FACE_RAD)
            for d in self.swept)]
        if not fresh:
            return None
        run = min(fresh, key=lambda r: float(np.linalg.norm(r["centre"] - np.asarray(from_xy)[:2])))
        self.swept.append(run)
        return run
