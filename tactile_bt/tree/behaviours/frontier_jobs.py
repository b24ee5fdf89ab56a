"""The moves a frontier scan asks for where sliding cannot reach, and what they found: the
re-approaches, border sweeps and corner probes of ``frontier_guidance``
(:mod:`tactile_bt.tree.behaviours.frontier`), as a mixin of its class over its bookkeeping
(:mod:`tactile_bt.tree.behaviours.frontier_left`).

When no reachable frontier is left but some is unexplained, the planner asks for a re-approach
(:mod:`tactile_bt.tree.behaviours.reapproach`) on ``reapproach_key``; when the band the table
left at the foot of plane faces, or a valley narrower than the pad, keeps the scan from its
coverage, a border sweep (:mod:`tactile_bt.tree.behaviours.border_sweep`) or a probe of the
valley with the pad's corner (:mod:`tactile_bt.tree.behaviours.hole_probe`). It applies what
each found when it goes on. While a sweep of a face's foot is left to make, ``sweep_due`` in
``/scan/frontier_left`` says so, for ``coverage_stalled`` to wait.

Layer: tree.
"""

from __future__ import annotations

import math

import numpy as np
from py_trees.common import Status
from scipy import ndimage

from tactile_bt import defaults
from tactile_bt.contacts.frontier_map import EXPLAINING, GAP, OPEN, WRIST, parts_touching, unexplained
from tactile_bt.contacts.hole_probe import below_rim_z, corner_first, probe_points, steep_rim_cells
from tactile_bt.contacts.sweep_plan import END_INSIDE_M, SweepPlan, foot_runs, to_corners, valley_sides
from tactile_bt.contacts.untouched import untouched_beyond
from tactile_bt.tree.behaviours.frontier_left import FrontierLeft
from tactile_bt.tree.blackboard import read_or, write
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE

__all__ = ["FrontierJobs"]

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
#: A band the table left at the foot of plane faces larger than this share of the touched area is
#: swept (when sweeps are on) even when the scan could end without it.
_BAND_WORTH = 0.01


class FrontierJobs(FrontierLeft):
    """The re-approaches, border sweeps and corner probes of a frontier planner (a mixin over
    :class:`FrontierLeft`; the planner also has ``plan``, ``pose``, ``ends`` and ``pad``)."""

    #: The valleys probed so far: ``centre`` (world xy, m), ``area_m2`` then and the probe's
    #: ``result`` (None until it comes).
    _probed: list = []
    #: The border sweeps of the scan (:class:`SweepPlan`), made at the first.
    sweeps: SweepPlan | None = None

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
                                 "are marked empty and leave the estimate; the band along its rim stays counted, but "
                                 "within half the pad's width (along the rim) of a point where the corner came below "
                                 "where the wall under the rim would stand at the tilt limit (as below): the rim falls "
                                 "away steeper than the pad may lie there, on average (the cells next to the touched "
                                 "edge stay counted: a rounded rim steepens gradually). A "
                                 "floor lower than this in a hollow narrower than the pad is taken for the table. "
                                 "Where no pose gets the corner this low at a point by the edge of a valley "
                                 "narrower than the pad, the point is probed where it is if the corner gets below "
                                 "where the wall under the rim would stand at the tilt limit (the rim's highest "
                                 "sample near it less 6 mm · tan 70°): touching above, it met surface within the "
                                 "pad's tilt, and the valley stays counted.")

    def frontier_left(self) -> dict:
        """:meth:`FrontierLeft.frontier_left`, and ``sweep_due`` (:meth:`sweep_due`)."""
        return {**super().frontier_left(), "sweep_due": self.sweep_due()}

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
            runs = foot_runs(self.face_xy, self.face_z, self.face_normals, foot_z)
            # on to the corners where the faces' feet meet, those swept before included: the frontier
            # stops short of them
            swept = [r for r in self.sweeps.swept if r.get("kind", "foot") == "foot"]
            run = self.sweeps.choose(to_corners(runs, min(self.pad.size_m), swept), from_xy, take)
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
                # and where a corner came below the wall at the tilt limit by the rim, nothing the pad
                # could lie on under it beyond the cells next to the touched edge: taken so along the
                # rim as far as the pad spans (its half-width)
                opened = [k for k, outcome in enumerate(job.get("outcomes", ())) if outcome == "open"]
                if opened:
                    xy = np.array([job["hole"]["probes"][k][0] for k in opened])
                    z = np.array([job["reached"][k] for k in opened])
                    self.map.mark_empty(steep_rim_cells(self.map, xy, z, self.max_tilt_rad, 0.5 * min(self.pad.size_m)),
                                        opened=True)
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
