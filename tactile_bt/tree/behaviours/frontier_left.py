"""What a frontier scan leaves, and the re-approaches it asks for: the bookkeeping of
``frontier_guidance`` (:mod:`tactile_bt.tree.behaviours.frontier`), as a mixin of its class.

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
why the pad stopped, but not the surface it left. When no
reachable frontier is left but some is unexplained, it asks for a re-approach
(:mod:`tactile_bt.tree.behaviours.reapproach`) on ``reapproach_key``, and applies the result
when it goes on.

Layer: tree.
"""

from __future__ import annotations

import math

import numpy as np
from py_trees.common import Status
from scipy import ndimage

from tactile_bt import defaults
from tactile_bt.contacts.frontier_map import EXPLAINING, GAP, OPEN, VALLEY, WRIST, parts_touching, unexplained
from tactile_bt.contacts.hole_probe import below_rim_z, corner_first, probe_points
from tactile_bt.contacts.sweep_plan import END_INSIDE_M, SweepPlan, foot_runs, valley_sides
from tactile_bt.contacts.untouched import face_going_on, untouched_below, untouched_beyond
from tactile_bt.tree.blackboard import read_or, write
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE, between

__all__ = ["FrontierLeft", "FRONTIER_LEFT_KEY"]

#: Holes in the touched area up to this many times the pad's width across are swept with its border.
_SWEPT_HOLES = 2.0
#: A valley is probed at most at this many points, and not again within this distance (m) of
#: one probed before; the probe keeps every part of the pad this far (m) above the touched
#: surface.
_HOLE_POINTS = 5
_HOLE_AGAIN_M = 0.02
#: A valley whose probe touched surface is probed again (within ``max_hole_probes``) once sliding
#: has shrunk it to this share of its area then: the corner met a wall under the rim that the
#: map had not seen yet, which the flat pad has touched since.
_HOLE_SHRUNK = 0.8
_HOLE_CLEARANCE_M = 0.002
#: Where the corner cannot go deep enough at a point (nor, by the edge of a valley narrower than
#: the pad, low enough to tell the wall under the rim: ``below_rim_z``), the points tried instead,
#: as fractions of the way from it to the valley's middle.
_HOLE_INWARDS = (0.0, 0.15, 0.3, 0.45)
#: A far probe's pad lies this far (m) beyond the frontier at its nearest corner.
_FAR_M = 0.003
#: Blackboard key of the frontier left (see :meth:`FrontierLeft.frontier_left`).
FRONTIER_LEFT_KEY = "/scan/frontier_left"
#: A band the table left at the foot of plane faces larger than this share of the touched area is
#: swept (when sweeps are on) even when the scan could end without it.
_BAND_WORTH = 0.01


class FrontierLeft:
    """The frontier left, the re-approaches and the border sweeps of a frontier planner (a mixin;
    the planner has ``map``, ``plan``, ``left``, ``coverage``, ``below_m2``, ``valley_m2``, its
    contact cloud ``_cloud`` and its table and tilt settings)."""

    valley_m2 = 0.0
    #: Estimated untouched area (m², table plane) along the rims of holes a probe found open.
    hole_rim_m2 = 0.0
    #: The valleys probed so far: ``centre`` (world xy, m), ``area_m2`` then and the probe's
    #: ``result`` (None until it comes).
    _probed: list = []
    #: Estimated untouched area (m², table plane) beyond the frontier the arm's reach explains.
    beyond_reach_m2 = 0.0
    #: The border sweeps of the scan (:class:`SweepPlan`), made at the first.
    sweeps: SweepPlan | None = None
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
    reapproach_key = Parameter("", fixed=True,
                               doc="Blackboard key of re-approaches (``reapproach`` reads it; empty: none). When no "
                                   "reachable frontier is left but some is unexplained, the leaf writes a re-approach "
                                   "of the nearest unexplained frontier not tried before there and FAILS, for a "
                                   "``retry`` to run ``reapproach`` and start exploring again; it applies the result "
                                   "when it starts again.")
    max_reapproaches = Parameter(20, bound=NON_NEGATIVE, unit=None, doc="Most re-approaches of one scan.")
    probe_beyond_m = Parameter(0.02, bound=POSITIVE,
                               doc="A re-approach probes this far beyond the frontier (m); it does not try again "
                                   "within this distance of a frontier tried before.")
    max_sweeps = Parameter(0, bound=NON_NEGATIVE, unit=None,
                           doc="Most border sweeps of one scan (0: none). When the band the table left below plane "
                               "faces, or a valley narrower than the pad, keeps the estimated coverage under "
                               "``min_coverage`` and nothing else is left, the leaf writes a sweep of the nearest run "
                               "of foot, or else side of a valley, not swept before to ``reapproach_key`` "
                               "(``{\"sweep\": ...}``, for ``border_sweep``) and FAILS, as for a re-approach.")
    max_hole_probes = Parameter(0, bound=NON_NEGATIVE, unit=None,
                                doc="Most valleys probed with the pad's corner in one scan (0: none). When a valley "
                                    "narrower than the pad keeps the estimated coverage under ``min_coverage`` and "
                                    "nothing else is left, the leaf writes a probe of the nearest valley not probed "
                                    "before to ``reapproach_key`` (``{\"hole\": ...}``, for ``hole_probe``) and FAILS, "
                                    "as for a re-approach: a valley the touched area encloses (a ring's hole) before "
                                    "any sweep, the others once no sweep is left to ask for. A hole wider than the pad "
                                    "(up to twice its width) that unexplained frontier faces is probed the same way, "
                                    "before any sweep. A probe that touched surface leaves its valley to be probed "
                                    "again once sliding has shrunk it to 80 % of its area then.")
    hole_floor_m = Parameter(0.02, bound=NON_NEGATIVE,
                             doc="A valley whose probes lowered the pad's corner to within this height (m) of the "
                                 "table touching nothing, at its middle and at points 6 mm inside its edge, is a "
                                 "hole (the table seen through a ring): its cells farther than 4 mm from its edge "
                                 "are marked empty and leave the estimate; the band along its rim stays counted. A "
                                 "floor lower than this in a hollow narrower than the pad is taken for the table. "
                                 "Where no pose gets the corner this low at a point by the edge of a valley "
                                 "narrower than the pad, the point is probed where it is if the corner gets below "
                                 "where the wall under the rim would stand at the tilt limit (the rim's highest "
                                 "sample near it less 6 mm · tan 70°): touching above, it met surface within the "
                                 "pad's tilt, and the valley stays counted.")
    foot_height_m = Parameter(0.002, bound=POSITIVE,
                              doc="Height (m) above the table of the level pad sweeping a face's foot: its border "
                                  "touches the face this high.")


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
                "near_table": self.face_left(), "sweep_due": self.sweep_due()}

    def band_worth_sweeping(self) -> bool:
        """Whether the band the table left at the foot of plane faces is over 1 % of the touched
        area: worth a border sweep even when the scan could end without it."""
        return self.map is not None and self.below_m2 > _BAND_WORTH * self.map.touched_area()

    def sweep_due(self) -> bool:
        """Whether a border sweep is due before the scan may end (``sweep_due`` in
        :meth:`frontier_left`, which ``coverage_stalled`` waits for): the band at the foot is
        worth sweeping (:meth:`band_worth_sweeping`) and a sweep is left to make, so that with no
        reachable frontier left the planner would ask for it rather than succeed."""
        return self.band_worth_sweeping() and self._next_sweep(self.pose[:2, 3]) is not None

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

    def _reapproach(self, point: np.ndarray, reasons: frozenset | None = None) -> dict | None:
        """Write a re-approach of the nearest unexplained frontier (or frontier left for one of
        ``reasons``) not tried before to ``reapproach_key`` and return it; None when there is
        none to try. When the estimated coverage reaches ``min_coverage`` and no run of
        unexplained frontier is longer than the pad's width, frontier tried before gets a far
        probe (:class:`~tactile_bt.contacts.reapproach_plan.ReapproachPlan`)."""
        if not self.reapproach_key or len(self.plan.tried) >= self.max_reapproaches:
            return None
        rows, cols, out, reason = self._classify()
        # frontier tried before is far-probed only where explaining it is all the scan lacks, and
        # no run of it is longer than one far probe closes (the pad's width): a far probe tells an
        # edge that drops away, it does not explore (lowered blind beside a bulging side, it
        # presses under the bulge)
        left = unexplained(reason)
        last = self.coverage >= self.min_coverage and \
            self.map.longest_run_m(rows[left], cols[left]) <= min(self.pad.size_m)
        far_m = self._far_m() if last else 0.0
        job = self.plan.choose(self.map, rows, cols, out, reason, point[:2], self.max_tilt_rad - self.tilt_margin_rad,
                               reasons, far_m=far_m, table_z_m=self.table_z_m)
        if job is None:
            return None
        job["home"] = (self.pose[:3, 3].copy(), -self.pose[:3, 2].copy())  # the pad as it lies now
        write(self.reapproach_key, job)
        return job

    def _far_m(self) -> float:
        """How far (m) beyond its frontier a far probe's pad is centred: its nearest corner
        :data:`_FAR_M` beyond it."""
        return self.pad.half_diagonal_m + self.corner_margin_m + _FAR_M

    def _sweep(self, point: np.ndarray, open_rims: bool = True) -> dict | None:
        """Write a border sweep to ``reapproach_key`` and return it: of the nearest run of foot
        below the frontier the table explains on plane faces, or else of the nearest side of a
        valley (with ``open_rims`` False, not of the band along a hole found open), not swept
        before; None when there is none (or sweeps are off)."""
        run = self._next_sweep(point[:2], open_rims, take=True)
        if run is None:
            return None
        job = {"sweep": run, "foot_z": self.table_z_m + self.foot_height_m, "top_z": float(np.nanmax(self.map.z_max)),
               "home": (self.pose[:3, 3].copy(), -self.pose[:3, 2].copy())}
        write(self.reapproach_key, job)
        return job

    def _next_sweep(self, from_xy: np.ndarray, open_rims: bool = True, take: bool = False) -> dict | None:
        """The border sweep :meth:`_sweep` would make from ``from_xy`` (world, m), counted as made
        with ``take``; None when there is none (or sweeps are off)."""
        if not self.reapproach_key or not self.max_sweeps or self.map is None:
            return None
        if self.sweeps is None:
            # a foot's sweep covers its run and the border's overhang beyond each end
            self.sweeps = SweepPlan(most=self.max_sweeps, reach_m=END_INSIDE_M)
        foot_z = self.table_z_m + self.foot_height_m
        run = None
        if self.below_m2 > 0 and math.isfinite(foot_z):
            run = self.sweeps.choose(foot_runs(self.face_xy, self.face_z, self.face_normals, foot_z), from_xy, take)
        if run is None:  # every hole in the touched area up to twice the pad across, whether an attempt has
            # failed at its rim or not: a flat pad bridges the narrower, and the sides of the wider may be
            # too steep or too curved for it (the inside of a ring)
            holes = self.map.valleys(_SWEPT_HOLES * min(self.pad.size_m), open_rims=open_rims)
            run = self.sweeps.choose(valley_sides(self.map, holes), from_xy, take)
        return run

    def _probe_hole(self, point: np.ndarray, wide: bool = False, enclosed: bool = False) -> dict | None:
        """Write a probe of the nearest valley not probed before (or probed and touched, and
        shrunk since to :data:`_HOLE_SHRUNK` of its area then; see ``max_hole_probes``) to
        ``reapproach_key`` and return it; None when there is none (or probes are off). With
        ``wide``, of the nearest hole in the touched area wider than the pad (up to twice its
        width) at whose rim an attempt failed unexplained instead: the pad fits in it, but
        slides over no rim that falls away out of its tilt, and cannot tell whether the hole has
        a floor. With ``enclosed``, of the valleys that the touched area encloses only (a ring's
        hole, not a channel running off the object)."""
        if not self.reapproach_key or self.map is None or len(self._probed) >= self.max_hole_probes \
                or not math.isfinite(self.table_z_m) or (self.valley_m2 <= 0 and not wide):
            return None
        width = min(self.pad.size_m)
        if wide:
            mask = self.map.valleys(_SWEPT_HOLES * width, channels=False) & ~self.map.valleys(width)
            rows, cols, _, reason = self._classify()
            failed = np.array([r not in EXPLAINING and r not in (OPEN, GAP) for r in reason], dtype=bool)
            rim = np.zeros_like(mask)
            rim[rows[failed], cols[failed]] = True
            mask = parts_touching(ndimage.label(mask)[0], rim)
        else:
            mask = self.map.valleys(width, channels=not enclosed)
        valleys = probe_points(self.map, mask, _HOLE_POINTS)
        valleys = [v for v in valleys if all(np.linalg.norm(v["centre"] - p["centre"]) > _HOLE_AGAIN_M
                                             or (p["result"] == "touched" and v["area_m2"] <= _HOLE_SHRUNK * p["area_m2"])
                                             for p in self._probed)]
        if not valleys:
            return None
        valley = min(valleys, key=lambda v: float(np.linalg.norm(v["centre"] - point[:2])))
        floor = self.table_z_m + self.table_clearance_m
        probes, near = [], self.pose[:3, :3]
        deep = self.table_z_m + self.hole_floor_m
        for k, point_xy in enumerate(valley["points"]):  # each pose deep enough turned as little as it can be from the one before
            for inwards in _HOLE_INWARDS:  # where the corner cannot go deep enough, a little nearer the middle
                xy = point_xy + inwards * (valley["centre"] - point_xy)
                enough = deep
                if k and not inwards and not wide:  # under the rim of a valley the pad bridges: low enough to tell its wall
                    enough = max(deep, below_rim_z(self.map, xy, valley["inside_m"], self.max_tilt_rad))
                pose = corner_first(self.map, xy, self.pad.size_m, self.max_tilt_rad, _HOLE_CLEARANCE_M, floor, near,
                                    deep_enough_z=enough - _HOLE_CLEARANCE_M)
                if pose is not None and pose[1] <= enough:
                    probes.append((xy, pose[0], pose[1]))
                    near = pose[0]
                    break
        if len(probes) < len(valley["points"]):
            return None  # the corner cannot go deep enough everywhere: the probe could not tell
        self._probed.append({"centre": valley["centre"], "area_m2": valley["area_m2"], "result": None})
        job = {"hole": {"probes": probes, "cells": valley["cells"], "centre": valley["centre"]},
               "top_z": float(np.nanmax(self.map.z_max)),
               "home": (self.pose[:3, 3].copy(), -self.pose[:3, 2].copy())}
        write(self.reapproach_key, job)
        return job

    def _asked_probe(self, point: np.ndarray, detail: str, wide: bool = False, enclosed: bool = False) -> bool:
        """Ask for a probe of a valley, or with ``wide`` of a hole wider than the pad, or with
        ``enclosed`` of a valley the touched area encloses (:meth:`_probe_hole`), and say so in
        the feedback message; False when there is none to ask for."""
        job = self._probe_hole(point, wide, enclosed)
        if job is None:
            return False
        x, y = job["hole"]["centre"] * 1e3
        self.feedback_message = (f"probing the {'hole' if wide else 'valley'} at ({x:.0f}, {y:.0f}) mm with the pad's corner at "
                                 f"{len(job['hole']['probes'])} points: {detail}")
        return True

    def _asked_unwind(self, point: np.ndarray, detail: str) -> bool:
        """Ask for a re-approach of the nearest frontier a wound wrist stopped (:data:`WRIST`)
        not tried before, which ``reapproach`` makes with the pad turned back a quarter turn, and
        say so in the feedback message; False when there is none to ask for, or no surface is
        estimated beyond it."""
        rows, cols, out, reason = self._classify()
        wound = reason == WRIST
        if not np.any(wound) or untouched_beyond(self.map, rows[wound], cols[wound], out[wound],
                                                 self.max_tilt_rad - self.tilt_margin_rad, self._cloud.points,
                                                 defaults.COVERAGE_RADIUS_M, self.table_z_m) <= 0:
            return False
        job = self._reapproach(point, frozenset({WRIST}))
        if job is None:
            return False
        x, y = job["frontier_xy"] * 1e3
        self.feedback_message = f"re-approaching the frontier at ({x:.0f}, {y:.0f}) mm the wrist stopped: {detail}"
        return True

    def _asked_sweep(self, point: np.ndarray, detail: str, open_rims: bool = True) -> bool:
        """Ask for a border sweep (:meth:`_sweep`) and say so in the feedback message; False
        when there is none to ask for."""
        job = self._sweep(point, open_rims)
        if job is None:
            return False
        x, y = job["sweep"]["centre"] * 1e3
        what = "the foot of the face" if job["sweep"]["kind"] == "foot" else "the side of the valley"
        self.feedback_message = f"sweeping {what} at ({x:.0f}, {y:.0f}) mm: {detail}"
        return True

    def _verdict(self) -> Status:
        """FAILURE for good (:attr:`feedback_message` says why): written to ``reapproach_key`` as
        ``{"verdict": message}``, on which ``reapproach`` fails at once rather than let a
        ``retry`` touch again."""
        if self.reapproach_key:
            write(self.reapproach_key, {"verdict": self.feedback_message})
        return Status.FAILURE

    def _reapproached(self) -> None:
        """Apply the result of a carried-out re-approach to the map, once."""
        job = read_or(self.reapproach_key) if self.reapproach_key else None
        if self.map is None or not isinstance(job, dict) or "result" not in job or job.get("applied"):
            return
        job["applied"] = True
        while job.get("return"):  # back to the last contact after a touch found nothing: no frontier
            job = job.get("pending")  # news, but what the job before it found may be
            if not isinstance(job, dict) or job.get("applied"):
                return
            job["applied"] = True
        if "hole" in job:
            for probed in self._probed:
                if probed["result"] is None and np.allclose(probed["centre"], job["hole"]["centre"]):
                    probed["result"] = job["result"]
            if job["result"] == "open":  # the table seen through it: no surface to scan there
                self.map.mark_empty(job["hole"]["cells"], opened=True)
            self.ends[f"hole probe: {job['result']}"] += 1
            return
        if "sweep" in job:
            if job.get("empty"):  # where the border went down to the table touching nothing
                self.map.mark_empty(np.vstack(job["empty"]))
            self.ends[f"{job['sweep'].get('kind', 'border')} sweep: {job['result']}"] += 1
            return
        result = self.plan.apply(self.map, job, far_m=self._far_m(),
                                 table_z_m=self.table_z_m, half_width_m=0.5 * min(self.pad.size_m))
        self.ends[f"{'far ' if job.get('far') else ''}re-approach: {result}"] += 1
