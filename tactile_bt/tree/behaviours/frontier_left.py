"""What a frontier scan leaves: the bookkeeping of ``frontier_guidance``
(:mod:`tactile_bt.tree.behaviours.frontier`), as a mixin of its class.

At every choice of a target the planner classifies its frontier
(:meth:`tactile_bt.contacts.frontier_map.FrontierMap.classify`) and sums it by reason: the
object's foot at the table, a surface steeper than the tilt limit, a place the arm could not
reach and the rim of a hollow narrower than the pad where an attempt failed (a valley the flat
pad bridges; its area counts as untouched in the estimated coverage) explain it
(:data:`~tactile_bt.contacts.frontier_map.EXPLAINING`); a stall, a jump, a lost
contact, a target not reached in time or an untried frontier do not. It writes the sums to
``/scan/frontier_left`` for ``coverage_stalled`` and the report, with an estimate of the area
left between the table and the frontier the table explains, where that frontier lies on a
plane face that goes on down to the table (the pad cannot lie on it lower without its border at
the table) and runs along its foot, as a border sweep would take it: there the table explains
why the pad stopped, but not the surface it left. The moves it asks for where sliding cannot
reach are those of :mod:`tactile_bt.tree.behaviours.frontier_jobs`.

Layer: tree.
"""

from __future__ import annotations

import numpy as np

from tactile_bt import defaults
from tactile_bt.contacts.frontier_map import EXPLAINING, GAP, OPEN, VALLEY, WRIST
from tactile_bt.contacts.sweep_plan import foot_runs
from tactile_bt.contacts.untouched import face_going_on, untouched_below, untouched_beyond
from tactile_bt.tree.blackboard import write
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE, between

__all__ = ["FrontierLeft", "FRONTIER_LEFT_KEY"]

#: Blackboard key of the frontier left (see :meth:`FrontierLeft.frontier_left`).
FRONTIER_LEFT_KEY = "/scan/frontier_left"


class FrontierLeft:
    """The frontier left by a frontier planner and the estimated coverage (a mixin;
    the planner has ``map``, ``plan``, ``left``, ``coverage``, ``below_m2``, ``valley_m2``, its
    contact cloud ``_cloud`` and its table and tilt settings)."""

    valley_m2 = 0.0
    #: Estimated untouched area (m², table plane) along the rims of holes a probe found open.
    hole_rim_m2 = 0.0
    #: Estimated untouched area (m², table plane) beyond the frontier the arm's reach explains.
    beyond_reach_m2 = 0.0
    face_normals = np.zeros((0, 3))

    max_unexplained_m = Parameter(0.01, bound=NON_NEGATIVE,
                                  doc="When no reachable frontier is left, the leaf succeeds only if at most this much "
                                      "of the frontier left (m, in cell edges) has no explaining reason (the table, "
                                      "the tilt limit, the arm's reach), and fails otherwise, naming what is left.")
    min_coverage = Parameter(0.0, bound=between(0, 1), unit=None,
                             doc="The leaf succeeds only when the touched area is at least this fraction of the "
                                 "touched area and the estimated area left between the table and the frontier the "
                                 "table explains where that frontier lies on a plane face (its normal turns by less "
                                 "than 5° over the 10 mm inwards) and runs along it (a run of foot, as a border "
                                 "sweep takes it: a few cells apart are a corner's): the face taken to go on down "
                                 "to the table at its slope (0 = no such test). A rounded side steepening towards "
                                 "the table, or an edge the pad rolled over, adds nothing: what lies below is steeper than anything "
                                 "touched. The valleys that explain frontier (holes in the touched area narrower than "
                                 "the pad) add their area, and so does the surface taken to go on beyond the "
                                 "frontier the arm's reach explains (10 mm of it, less where it steepens past the "
                                 "tilt limit sooner).")
    foot_height_m = Parameter(0.0015, bound=POSITIVE,
                              doc="Height (m) above the table of the level pad sweeping a face's foot: its border "
                                  "touches the face this high, this over the sine of the face's slope from the "
                                  "table up the face. No lower than where the table guard's brake holds the corners "
                                  "(``min_clearance_m`` plus ``brake_margin_m`` of ``table_clearance``, 1.5 mm in the "
                                  "shipped tree): the brake would lift the pad.")


    def _classify(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Rows, columns, outward directions and reasons of the frontier cells (see
        :meth:`FrontierMap.classify`; :data:`OPEN` for the reachable, unblocked ones)."""
        return self.map.classify(self.max_tilt_rad - self.tilt_margin_rad, self.table_z_m, self.table_clearance_m,
                                 min(self.pad.size_m))

    def _candidates(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rows, columns and outward directions of the reachable, unblocked frontier cells."""
        rows, cols, out, reason = self._classify()
        names, counts = np.unique(reason[reason != GAP].astype(str), return_counts=True)
        self.left = {str(k): float(c) * self.cell_m for k, c in zip(names, counts)}
        # the table kept the pad from the surface below these: how much is left there
        band = reason == "table"
        reach = self.pad.half_diagonal_m + self.corner_margin_m  # contact to the farthest corner
        steep = self.max_tilt_rad - self.tilt_margin_rad
        face = face_going_on(self.map, rows[band], cols[band], out[band], steep, self.table_z_m, reach)
        r, c = rows[band][face], cols[band][face]
        xy, z, normals = self.map.centre_of(r, c), self.map.z_max[r, c], self.map.mean_normal(r, c)
        kept = self._in_foot_runs(xy, z, normals)
        face[np.flatnonzero(face)[~kept]] = False
        self.face_xy, self.face_z, self.face_normals = xy[kept], z[kept], normals[kept]
        below = untouched_below(self.map, rows[band], cols[band], out[band], self.table_z_m, steep,
                                self._cloud.points, defaults.COVERAGE_RADIUS_M, reach, face)
        # the valleys a flat pad bridges stay untouched: their area counts (the whole hole, which
        # may be partly the table seen through a ring: the estimate errs towards failing)
        valleys = self.map.valleys(min(self.pad.size_m)) if np.any(reason == VALLEY) else None
        valley = float(np.count_nonzero(valleys)) * self.cell_m**2 if valleys is not None else 0.0
        # the band a probe left along the rim of a hole it found open (not counted as a valley already)
        rims = self.map.hole_rims() if self.map.opened.any() else None
        if rims is not None and valleys is not None:
            rims &= ~valleys
        rim = float(np.count_nonzero(rims)) * self.cell_m**2 if rims is not None else 0.0
        # the arm stopped the pad there, not the surface: it goes on (see untouched_beyond)
        far = (reason == "reach") | (reason == WRIST)
        beyond = untouched_beyond(self.map, rows[far], cols[far], out[far], steep, self._cloud.points,
                                  defaults.COVERAGE_RADIUS_M, self.table_z_m)
        touched = self.map.touched_area()
        self.coverage = touched / (touched + below + valley + rim + beyond) if touched > 0 else 0.0
        self.below_m2 = below
        self.valley_m2 = valley
        self.hole_rim_m2 = rim
        self.beyond_reach_m2 = beyond
        write(FRONTIER_LEFT_KEY, self.frontier_left())
        ok = reason == OPEN
        return rows[ok], cols[ok], out[ok]

    def _in_foot_runs(self, xy: np.ndarray, z: np.ndarray, normals: np.ndarray) -> np.ndarray:
        """Which of the frontier cells on plane faces going on down to the table (their centres
        ``xy``, heights ``z`` and mean normals, world, m) belong to a run of foot
        (:func:`foot_runs`): a face's frontier runs along it, and a few cells apart are a
        corner's or an edge's the pad rolled over, whose samples lie in the tilted pad's plane (a
        box smaller than the pad). The band the estimate counts is the band a border sweep can
        reach."""
        kept = np.zeros(len(xy), dtype=bool)
        if len(xy):
            for run in foot_runs(xy, z, normals, self.table_z_m + self.foot_height_m):
                kept[run["cells"]] = True
        return kept

    def frontier_left(self) -> dict:
        """The frontier left at the last choice, ``{"explained": {reason: m}, "unexplained":
        {reason: m}}`` (lengths in cell edges; the reason "" is frontier still open), the
        estimated untouched area between the table and the frontier the table explains on plane
        faces (``untouched_near_table_m2``, m² in the table plane; see ``min_coverage``), in the
        valleys (``untouched_in_valleys_m2``) and beyond the frontier the arm's reach explains
        (``untouched_beyond_reach_m2``), the estimated coverage (the touched area over it and
        those and the bands along the rims of holes a probe found open,
        ``untouched_at_hole_rims_m2``; ``estimated_coverage``) and where that frontier lies (``near_table``,
        :meth:`face_left`)."""
        return {"explained": {k: v for k, v in self.left.items() if k in EXPLAINING},
                "unexplained": {k: v for k, v in self.left.items() if k not in EXPLAINING},
                "untouched_near_table_m2": self.below_m2, "untouched_in_valleys_m2": self.valley_m2,
                "untouched_beyond_reach_m2": self.beyond_reach_m2, "untouched_at_hole_rims_m2": self.hole_rim_m2,
                "estimated_coverage": self.coverage,
                "near_table": self.face_left()}

    def face_left(self) -> str:
        """Where the frontier on plane faces near the table lies (see ``min_coverage``): its
        length, heights above the table and extent in world x, y (mm)."""
        if not len(self.face_xy):
            return "no frontier on a plane face near the table"
        lo, hi = self.face_xy.min(axis=0) * 1e3, self.face_xy.max(axis=0) * 1e3
        z = (self.face_z - self.table_z_m) * 1e3
        return (f"{len(self.face_xy) * self.cell_m * 1e3:.0f} mm of frontier on plane faces {z.min():.0f}–{z.max():.0f} mm "
                f"above the table, x {lo[0]:.0f}…{hi[0]:.0f}, y {lo[1]:.0f}…{hi[1]:.0f} mm")

    def untouched_where(self) -> str:
        """Where the estimated coverage leaves surface untouched, for a failure's message: about
        how much of it in all, near the table, in valleys and beyond the arm's reach."""
        where = [f"{self.below_m2 * 1e4:.1f} cm² near the table below {self.face_left()}"] if self.below_m2 > 0 else []
        if self.valley_m2 > 0:
            where.append(f"{self.valley_m2 * 1e4:.1f} cm² in valleys narrower than the pad")
        if self.hole_rim_m2 > 0:
            where.append(f"{self.hole_rim_m2 * 1e4:.1f} cm² along the rims of holes")
        if self.beyond_reach_m2 > 0:
            reach = self.left.get("reach", 0.0) + self.left.get(WRIST, 0.0)
            where.append(f"{self.beyond_reach_m2 * 1e4:.1f} cm² beyond {reach * 1e3:.0f} mm of frontier "
                         "the arm could not reach")
        return f"about {100 * (1 - self.coverage):.0f} % of the surface untouched ({'; '.join(where)}"

    def standing(self) -> str:
        """The scan so far, for a mission whose time ran out (see ``TactileBehaviour.standing``):
        how much of the surface the estimate leaves untouched and where, and how much of the
        frontier left is unexplained; "" before the first contact."""
        if self.map is None:
            return ""
        left = self.below_m2 + self.valley_m2 + self.hole_rim_m2 + self.beyond_reach_m2
        parts = [f"{self.untouched_where()})" if left > 0 else f"estimated coverage {self.coverage:.2f}"]
        unexplained = self.unexplained_m()
        if unexplained > 0:
            parts.append(f"{unexplained * 1e3:.0f} mm of the frontier left unexplained")
        return "the scan so far: " + ", ".join(parts)

    def unexplained_m(self) -> float:
        """Length (m) of the frontier left without an explaining reason."""
        return sum(v for k, v in self.left.items() if k not in EXPLAINING)
