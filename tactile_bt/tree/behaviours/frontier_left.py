"""What a frontier scan leaves, and the re-approaches it asks for: the bookkeeping of
``frontier_guidance`` (:mod:`tactile_bt.tree.behaviours.frontier`), as a mixin of its class.

At every choice of a target the planner classifies its frontier
(:meth:`tactile_bt.contacts.frontier_map.FrontierMap.classify`) and sums it by reason: the
object's foot at the table, a surface steeper than the tilt limit and a place the arm could not
reach explain it (:data:`~tactile_bt.contacts.frontier_map.EXPLAINING`); a stall, a jump, a lost
contact, a target not reached in time or an untried frontier do not. It writes the sums to
``/scan/frontier_left`` for ``coverage_stalled`` and the report, with an estimate of the area
left between the table and the frontier where the table stopped a shallow pad. When no
reachable frontier is left but some is unexplained, it asks for a re-approach
(:mod:`tactile_bt.tree.behaviours.reapproach`) on ``reapproach_key``, and applies the result
when it goes on.

Layer: tree.
"""

from __future__ import annotations

import math

import numpy as np

from tactile_bt.contacts.frontier_map import EXPLAINING, GAP, OPEN
from tactile_bt.tree.blackboard import read_or, write
from tactile_bt.tree.declaration import Parameter
from tactile_bt.tree.parameters import NON_NEGATIVE, POSITIVE, between

__all__ = ["FrontierLeft", "FRONTIER_LEFT_KEY"]

#: Blackboard key of the frontier left (see :meth:`FrontierLeft.frontier_left`).
FRONTIER_LEFT_KEY = "/scan/frontier_left"


class FrontierLeft:
    """The frontier left and the re-approaches of a frontier planner (a mixin; the planner has
    ``map``, ``plan``, ``left``, ``coverage``, ``below_m2`` and its table and tilt settings)."""

    max_unexplained_m = Parameter(0.01, bound=NON_NEGATIVE,
                                  doc="When no reachable frontier is left, the leaf succeeds only if at most this much "
                                      "of the frontier left (m, in cell edges) has no explaining reason (the table, "
                                      "the tilt limit, the arm's reach), and fails otherwise, naming what is left.")
    min_coverage = Parameter(0.0, bound=between(0, 1), unit=None,
                             doc="The leaf succeeds only when the touched area is at least this fraction of the "
                                 "touched area and the estimated area left between the table and the frontier where "
                                 "the table stopped the pad while it was tilted less than ``max_tilt_rad - "
                                 "tilt_margin_rad`` (the run down to the table at the pad's tilt then; 0 = no such test: the "
                                 "estimate takes the surface below to go on at the pad's tilt, and a pad that rolled "
                                 "over a box's edge to the table leaves a vertical side that is no area at all).")
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


    def _classify(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Rows, columns, outward directions and reasons of the frontier cells (see
        :meth:`FrontierMap.classify`; :data:`OPEN` for the reachable, unblocked ones)."""
        return self.map.classify(self.max_tilt_rad - self.tilt_margin_rad, self.table_z_m, self.table_clearance_m)

    def _candidates(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rows, columns and outward directions of the reachable, unblocked frontier cells."""
        rows, cols, out, reason = self._classify()
        names, counts = np.unique(reason[reason != GAP].astype(str), return_counts=True)
        self.left = {str(k): float(c) * self.cell_m for k, c in zip(names, counts)}
        # the table kept the pad from the surface below these: how much is left there
        band = (reason == "table") & (self.map.z_max[rows, cols] > self.table_z_m + self.table_clearance_m)
        reach = math.hypot(*self.pad.size_m) / 2 + self.corner_margin_m  # contact to the farthest corner
        below = self.map.untouched_below(rows[band], cols[band], self.table_z_m,
                                         self.max_tilt_rad - self.tilt_margin_rad, reach)
        touched = self.map.touched_area()
        self.coverage = touched / (touched + below) if touched > 0 else 0.0
        self.below_m2 = below
        write(FRONTIER_LEFT_KEY, self.frontier_left())
        ok = reason == OPEN
        return rows[ok], cols[ok], out[ok]

    def frontier_left(self) -> dict:
        """The frontier left at the last choice, ``{"explained": {reason: m}, "unexplained":
        {reason: m}}`` (lengths in cell edges; the reason "" is frontier still open), the
        estimated untouched area between the table and the frontier the table kept the pad from
        (``untouched_near_table_m2``, m² in the table plane) and the estimated coverage (the
        touched area over it and that, ``estimated_coverage``)."""
        return {"explained": {k: v for k, v in self.left.items() if k in EXPLAINING},
                "unexplained": {k: v for k, v in self.left.items() if k not in EXPLAINING},
                "untouched_near_table_m2": self.below_m2, "estimated_coverage": self.coverage}

    def unexplained_m(self) -> float:
        """Length (m) of the frontier left without an explaining reason."""
        return sum(v for k, v in self.left.items() if k not in EXPLAINING)

    def _reapproach(self, point: np.ndarray) -> dict | None:
        """Write a re-approach of the nearest unexplained frontier not tried before to
        ``reapproach_key`` and return it; None when there is none to try."""
        if not self.reapproach_key or len(self.plan.tried) >= self.max_reapproaches:
            return None
        rows, cols, out, reason = self._classify()
        job = self.plan.choose(self.map, rows, cols, out, reason, point[:2], self.max_tilt_rad - self.tilt_margin_rad)
        if job is None:
            return None
        job["home"] = (self.pose[:3, 3].copy(), -self.pose[:3, 2].copy())  # the pad as it lies now
        write(self.reapproach_key, job)
        return job

    def _reapproached(self) -> None:
        """Apply the result of a carried-out re-approach to the map, once."""
        job = read_or(self.reapproach_key) if self.reapproach_key else None
        if self.map is None or not isinstance(job, dict) or "result" not in job or job.get("applied"):
            return
        job["applied"] = True
        result = self.plan.apply(self.map, job)
        self.ends[f"re-approach: {result}"] += 1
