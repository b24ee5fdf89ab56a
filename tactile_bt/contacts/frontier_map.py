"""Frontiers of a touched surface: an occupancy grid of the contact cloud in the table plane.

:class:`FrontierMap` bins contact samples (world points and outward normals) into ``cell_m``
cells of the table plane (world x, y). The *frontier* is the set of touched cells next to
untouched ones: an open boundary of the covered area, with the outward direction towards the
untouched side. Each frontier cell may be *blocked* per direction sector (an attempt to cross it
that way has failed), with the cause of the failure kept, and :meth:`FrontierMap.classify` tells
for every frontier cell why it is closed ("table": the object's foot at the table; "tilt": the
surface there is steeper than the pad may tilt; the cause of a block) or that it is still open
(""). :meth:`FrontierMap.remainder` sums the frontier by reason, for a scan's report of what it
left and why. Pure geometry: no time, no robot, no tree.

Layer: contacts.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage

__all__ = ["FrontierMap", "SECTORS", "SMALL_HOLE_CELLS", "OPEN", "GAP", "VALLEY", "HOLE", "HOLE_RIM_M", "WRIST",
           "EXPLAINING", "sector", "describe_left", "parts_touching", "unexplained"]

#: Untouched holes of at most this many cells count as touched (see :attr:`FrontierMap.touched`).
SMALL_HOLE_CELLS = 2
#: Number of direction sectors a cell is blocked in (45° each).
SECTORS = 8
#: The reason :meth:`FrontierMap.classify` gives an open (reachable, unblocked) frontier cell.
OPEN = ""
#: The reason of a frontier cell without a sample of its own (a gap between samples).
GAP = "gap"
#: The reason of a frontier cell where an attempt ended with the arm's wrist wound onto the limit
#: of the joint that turns the pad about its normal: the arm's reach as the pad was turned, which
#: a re-approach with the pad turned back a quarter turn may undo (see ``frontier_guidance``).
WRIST = "wrist"
#: Reasons of the frontier left that explain it (see :meth:`FrontierMap.classify`): the object's
#: foot at the table, a surface steeper than the pad may tilt, a place the arm cannot reach (a
#: re-approach found it so, or a joint held at its limit, the wrist's among them). Every other
#: reason (an edge, a stall, a jump, a lost contact, a target not reached in time, or no attempt
#: at all) leaves that frontier unexplained: the surface beyond may go on.
EXPLAINING = frozenset({"table", "tilt", "reach", "valley", "hole", WRIST})
#: The reason of a frontier cell where an attempt failed (a stall, a lost contact, ...) at the rim
#: of a *valley*: an untouched hole in the touched area, enclosed by it and narrower than the pad
#: (:meth:`FrontierMap.valleys`), which a flat pad bridges.
VALLEY = "valley"
#: The reason of a frontier cell where an attempt failed facing cells seen
#: :attr:`~FrontierMap.empty` and still untouched (no surface above the table there: a pad's border
#: or corner went down near the table touching nothing): the rim of a hole, beyond which the
#: surface falls away out of the pad's reach.
HOLE = "hole"
#: A probe that finds a hole open marks it empty only farther than this (m) from its edge: the
#: band along the rim, where the wall under a rim may be, stays untouched (see
#: :meth:`FrontierMap.hole_rims`).
HOLE_RIM_M = 0.004
#: 8-neighbour offsets (row = y, column = x) and their unit directions.
_OFFSETS = np.array([(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx])
_OFFSET_DIRS = _OFFSETS[:, ::-1] / np.linalg.norm(_OFFSETS, axis=1)[:, None]  # (x, y)


def parts_touching(labels: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """``(n, m)`` bool: the labelled parts of ``labels`` (``ndimage.label``'s output, 0 for
    none) that ``cells`` (bool, the same shape) touch, an 8-neighbour apart."""
    near = ndimage.binary_dilation(cells, structure=np.ones((3, 3), dtype=bool))
    keep = np.unique(labels[near & (labels > 0)])
    return np.isin(labels, keep)


def unexplained(reason: np.ndarray) -> np.ndarray:
    """``(k,)`` bool: which frontier cells of :meth:`FrontierMap.classify`'s ``reason`` have no
    explaining reason (not one of :data:`EXPLAINING`, nor a :data:`GAP`)."""
    return np.array([r not in EXPLAINING and r != GAP for r in reason], dtype=bool)


def sector(direction_xy: np.ndarray) -> np.ndarray:
    """Sector index (0..SECTORS-1) of world xy directions ``(..., 2)``."""
    angle = np.arctan2(direction_xy[..., 1], direction_xy[..., 0])
    return np.round(angle / (2 * math.pi / SECTORS)).astype(int) % SECTORS


def describe_left(left: dict) -> str:
    """One line for the frontier left, ``{"explained": {reason: m}, "unexplained": {reason: m}}``:
    "35 mm unexplained (20 edge, 15 open); 120 mm explained (100 table, 20 tilt)" (the rough
    area estimates beside them stay in the report's ``frontier``)."""
    parts = []
    for kind in ("unexplained", "explained"):
        lengths = left.get(kind) or {}
        total = sum(lengths.values())
        if total > 0:
            detail = ", ".join(f"{v * 1e3:.0f} {k or 'open'}" for k, v in sorted(lengths.items(), key=lambda kv: -kv[1]))
            parts.append(f"{total * 1e3:.0f} mm {kind} ({detail})")
    return "; ".join(parts) or "none"


class FrontierMap:
    """Occupancy grid of the touched surface in the table plane.

    ``cell_m`` cells over a square of half-size ``extent_m`` around ``centre`` (world x, y).
    Each cell holds the number of contact samples in it, the sum of their outward normals and the
    highest sample; ``blocked[row, col, sector]`` marks the directions in which an attempt to
    cross the cell has failed, and ``cause[row, col, sector]`` indexes :attr:`causes`: why it
    failed there last (-1: never), or what a re-approach found there (:meth:`close`).
    """

    def __init__(self, centre_xy, cell_m: float = 0.002, extent_m: float = 0.3) -> None:
        self.cell_m = float(cell_m)
        self.n = int(math.ceil(2 * extent_m / cell_m))
        self.origin = np.asarray(centre_xy, dtype=float)[:2] - 0.5 * self.n * self.cell_m
        self.count = np.zeros((self.n, self.n), dtype=np.int32)
        self.normal_sum = np.zeros((self.n, self.n, 3))
        self.z_max = np.full((self.n, self.n), -np.inf)
        #: Cells seen to hold no surface above the table (a border swept down to it touched nothing).
        self.empty = np.zeros((self.n, self.n), dtype=bool)
        #: Of those, the cells a probe found open: the inside of a hole, its rim left out (see
        #: :meth:`hole_rims`).
        self.opened = np.zeros((self.n, self.n), dtype=bool)
        #: Cells a flat pad was seen to bridge: it rested on contacts on both sides of them.
        self.hollow = np.zeros((self.n, self.n), dtype=bool)
        self.blocked = np.zeros((self.n, self.n, SECTORS), dtype=bool)
        self.cause = np.full((self.n, self.n, SECTORS), -1, dtype=np.int16)
        #: Index into :attr:`causes` of the reason a re-approach closed the cell for (-1: none,
        #: see :meth:`close`); it outlasts later blocks, until :meth:`unblock`.
        self.closed = np.full((self.n, self.n), -1, dtype=np.int16)
        #: The causes of blocks, in the order they first came.
        self.causes: list[str] = []
        self._row_any = np.zeros(self.n, dtype=bool)  # rows / columns holding a sample
        self._col_any = np.zeros(self.n, dtype=bool)

    def cell_of(self, xy: np.ndarray) -> np.ndarray:
        """(row, col) indices of world xy points ``(k, 2)``; may lie outside the grid."""
        ij = np.floor((np.asarray(xy)[..., :2] - self.origin) / self.cell_m).astype(int)
        return ij[..., ::-1]

    def centre_of(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """World xy (m) of the centres of cells ``(rows, cols)``, ``(k, 2)``."""
        return self.origin + (np.column_stack((cols, rows)) + 0.5) * self.cell_m

    def add(self, points: np.ndarray, normals: np.ndarray) -> int:
        """Add contact samples (world points and outward normals, ``(k, 3)``); returns how many
        fell inside the grid."""
        rc = self.cell_of(points)
        inside = np.all((rc >= 0) & (rc < self.n), axis=1)
        rows, cols = rc[inside, 0], rc[inside, 1]
        np.add.at(self.count, (rows, cols), 1)
        np.add.at(self.normal_sum, (rows, cols), normals[inside])
        np.maximum.at(self.z_max, (rows, cols), points[inside, 2])
        self._row_any[rows] = True
        self._col_any[cols] = True
        return int(inside.sum())

    def _window(self) -> tuple[slice, slice]:
        """The part of the grid around the touched cells (one cell of margin)."""
        rows = np.flatnonzero(self._row_any)
        cols = np.flatnonzero(self._col_any)
        if not len(rows):
            return slice(0, 0), slice(0, 0)
        return (slice(max(rows[0] - 1, 0), min(rows[-1] + 2, self.n)),
                slice(max(cols[0] - 1, 0), min(cols[-1] + 2, self.n)))

    @staticmethod
    def _touched(count: np.ndarray) -> np.ndarray:
        t = count > 0
        # gaps one cell wide between touched cells (either way, or diagonally)
        p = np.pad(t, 1)
        h, w = t.shape

        def at(dy: int, dx: int) -> np.ndarray:
            return p[1 + dy: 1 + dy + h, 1 + dx: 1 + dx + w]

        t = t | (at(0, -1) & at(0, 1)) | (at(-1, 0) & at(1, 0)) | (at(-1, -1) & at(1, 1)) | (at(-1, 1) & at(1, -1))
        holes, n = ndimage.label(~t)
        if n:
            sizes = np.bincount(holes.ravel())
            small = sizes <= SMALL_HOLE_CELLS
            small[0] = False
            t = t | small[holes]
        return t

    @property
    def touched(self) -> np.ndarray:
        """Cells holding a sample, the gaps one cell wide between them and the holes of at most
        :data:`SMALL_HOLE_CELLS` cells among them: with the imprint sampled every 2.5 mm on the
        pad, a line of 2 mm cells may stay empty between samples that cover it (within 2 mm)
        from both sides."""
        out = np.zeros((self.n, self.n), dtype=bool)
        w = self._window()
        out[w] = self._touched(self.count[w])
        return out

    def tilt(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Tilt (rad) from the vertical of the mean outward normal in the cells ``(rows, cols)``
        (NaN where untouched)."""
        s = self.normal_sum[rows, cols]
        norm = np.linalg.norm(s, axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.arccos(np.clip(s[..., 2] / norm, -1.0, 1.0))

    def frontier(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Rows, columns and outward directions ``(k, 2)`` (world xy, unit) of the frontier
        cells: touched cells with an untouched 8-neighbour; outward points to the untouched
        ones."""
        w = self._window()
        t = self._touched(self.count[w])
        h, wd = t.shape
        padded = np.pad(~t, 1, constant_values=True)
        out = np.zeros((h, wd, 2))
        for (dy, dx), d in zip(_OFFSETS, _OFFSET_DIRS):
            out[padded[1 + dy: 1 + dy + h, 1 + dx: 1 + dx + wd]] += d
        norm = np.linalg.norm(out, axis=2)
        rows, cols = np.nonzero(t & (norm > 1e-9))
        vec = out[rows, cols] / norm[rows, cols, None]
        return rows + w[0].start, cols + w[1].start, vec

    def _cause_index(self, cause: str) -> int:
        if cause not in self.causes:
            self.causes.append(cause)
        return self.causes.index(cause)

    def block_cells(self, rows: np.ndarray, cols: np.ndarray, directions_xy: np.ndarray, cause: str = "") -> None:
        """Block the cells ``(rows, cols)`` each for crossings in its own direction (``(k, 2)``,
        world xy) and the two neighbouring sectors, for ``cause``."""
        s = sector(np.asarray(directions_xy, dtype=float))
        c = self._keep_closed(rows, cols, self._cause_index(cause))
        for k in (-1, 0, 1):
            self.blocked[rows, cols, (s + k) % SECTORS] = True
            self.cause[rows, cols, (s + k) % SECTORS] = c

    def block(self, centre_xy, radius_m: float, direction_xy, rows=None, cols=None, cause: str = "") -> int:
        """Block the cells within ``radius_m`` (m) of ``centre_xy`` (world xy; and the cells
        ``rows, cols``) for crossings in ``direction_xy`` and its two neighbouring sectors, for
        ``cause``; returns how many cells were newly blocked in the direction's own
        sector."""
        d = np.asarray(direction_xy, dtype=float)[:2]
        s = int(sector(d))
        rr, cc = self.disc(centre_xy, radius_m)
        if rows is not None:
            rr = np.concatenate((rr, np.asarray(rows, dtype=int)))
            cc = np.concatenate((cc, np.asarray(cols, dtype=int)))
        before = int(self.blocked[rr, cc, s].sum())
        c = self._keep_closed(rr, cc, self._cause_index(cause))
        for k in (s - 1, s, s + 1):
            self.blocked[rr, cc, k % SECTORS] = True
            self.cause[rr, cc, k % SECTORS] = c
        return int(self.blocked[rr, cc, s].sum()) - before

    def disc(self, centre_xy, radius_m: float) -> tuple[np.ndarray, np.ndarray]:
        """Rows and columns of the grid's cells within ``radius_m`` (m, rounded up to cells) of
        the cell of ``centre_xy`` (world xy)."""
        c = self.cell_of(np.asarray(centre_xy, dtype=float)[None, :2])[0]
        r = int(math.ceil(radius_m / self.cell_m))
        lo, hi = np.maximum(c - r, 0), np.minimum(c + r + 1, self.n)
        if np.any(hi <= lo):
            return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
        rr, cc = np.mgrid[lo[0]:hi[0], lo[1]:hi[1]]
        inside = (rr - c[0]) ** 2 + (cc - c[1]) ** 2 <= r * r
        return rr[inside], cc[inside]

    def _keep_closed(self, rows: np.ndarray, cols: np.ndarray, cause: int) -> np.ndarray:
        """The cause index to write for the cells ``(rows, cols)``: ``cause``, or, where it
        explains nothing, the explaining reason a re-approach closed the cell for (:meth:`close`)."""
        if self.causes[cause] in EXPLAINING:
            return np.full(len(np.atleast_1d(rows)), cause, dtype=np.int16)
        closed = self.closed[rows, cols]
        return np.where(closed >= 0, closed, cause).astype(np.int16)

    def valleys(self, max_width_m: float, channels: bool = True, open_rims: bool = True) -> np.ndarray:
        """``(n, n)`` bool: the untouched cells of hollows a flat pad ``max_width_m`` wide bridges.

        - Holes in the touched area, enclosed by it (not connected to the untouched surroundings)
          and at most ``max_width_m`` across their narrower side (of their bounding box in the
          grid).
        - Channels open at their ends (a groove running off the object) that the pad was seen to
          bridge (:meth:`mark_bridged`): untouched cells connected to the untouched surroundings
          that the touched area closes over (a morphological closing with a disc ``max_width_m``
          across), in parts that hold cells the pad rested across. A bridge seen beyond the
          touched area explains nothing there, nor one across a hole the touched area encloses
          (a ring's hole wider than the pad, which the pad bridges along its chords).

        Cells seen :attr:`empty` belong to no hollow (the table seen through a ring). With
        ``channels`` False, the enclosed holes only; with ``open_rims`` False, not the band a
        probe leaves along the rim of a hole it found open either (:meth:`hole_rims`: the
        frontier facing it is that hole's, explained already)."""
        out = np.zeros((self.n, self.n), dtype=bool)
        w = self._window()
        t = self._touched(self.count[w])
        if max_width_m <= 0 or not t.any():
            return out
        free = ~t & ~self.empty[w]
        holes, n = ndimage.label(free)
        if not n:
            return out
        outside = np.unique(np.concatenate((holes[0], holes[-1], holes[:, 0], holes[:, -1])))
        keep = np.zeros(n + 1, dtype=bool)
        for k, box in enumerate(ndimage.find_objects(holes), start=1):
            if box is not None and k not in outside:
                height, width = (sl.stop - sl.start for sl in box)
                keep[k] = min(height, width) * self.cell_m <= max_width_m
        found = keep[holes]
        if channels:  # in what runs off into the untouched surroundings only: a wider hole is no channel
            runs_off = np.isin(holes, outside) & (holes > 0)
            found |= self._channels(t, runs_off & ~found, 0.5 * max_width_m / self.cell_m, self.hollow[w])
        if not open_rims and self.opened[w].any():  # what lies along a hole found open
            found &= ~parts_touching(holes, self.opened[w])
        out[w] = found
        return out

    def _channels(self, t: np.ndarray, free: np.ndarray, radius: float, bridged: np.ndarray) -> np.ndarray:
        """The cells of ``free`` (window-sized) that the closing of the touched window ``t`` by a
        disc of ``radius`` cells covers, in parts that hold cells seen ``bridged`` (see
        :meth:`valleys`)."""
        if not bridged.any():
            return np.zeros_like(free)
        margin = int(math.ceil(radius)) + 1
        grown = ndimage.distance_transform_edt(~np.pad(t, margin)) <= radius
        closed = (ndimage.distance_transform_edt(grown) > radius)[margin:-margin, margin:-margin]
        parts, n = ndimage.label(closed & free)
        keep = np.zeros(n + 1, dtype=bool)
        keep[np.unique(parts[bridged & (parts > 0)])] = True  # the pad rested on both sides
        keep[0] = False
        return keep[parts]

    def classify(self, max_tilt_rad: float, table_z_m: float = math.nan, table_clearance_m: float = 0.0,
                 valley_m: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Rows, columns, outward directions ``(k, 2)`` and reasons ``(k,)`` (str) of the
        frontier cells. The reason is "table" where the highest sample of the cell lies within
        ``table_clearance_m`` of the table (``table_z_m``, world z; NaN: no table): the object's
        foot; "tilt" where the touched surface is tilted more than ``max_tilt_rad`` from the
        vertical; the cause of the block in the outward direction where an attempt to cross it
        has failed, or :data:`VALLEY` where that attempt faced a hole of the touched area at most
        ``valley_m`` across (:meth:`valleys`; 0: none); :data:`HOLE` where that attempt (not
        explained otherwise) faced cells seen :attr:`empty` and still untouched, or the band a
        probe left along the rim of a hole it found open (:meth:`hole_rims`); :data:`GAP` in
        the cells that count as touched without a sample of their own (between samples, see
        :attr:`touched`);
        :data:`OPEN` ("") where the frontier is still to be crossed."""
        rows, cols, out = self.frontier()
        reason = np.full(len(rows), OPEN, dtype=object)
        if not len(rows):
            return rows, cols, out, reason
        c = self.cause[rows, cols, sector(out)]
        blocked = self.blocked[rows, cols, sector(out)]
        names = np.array(self.causes + [OPEN], dtype=object)
        reason[blocked] = names[c[blocked]]
        if valley_m > 0 and blocked.any():
            rim = ndimage.binary_dilation(self.valleys(valley_m), structure=np.ones((3, 3), dtype=bool))
            facing = rim[rows, cols] & blocked  # a neighbour of the cell lies in the valley
            failed = np.array([r not in EXPLAINING for r in reason], dtype=bool)
            reason[facing & failed] = VALLEY
        if self.empty.any() and blocked.any():
            seen = (self.empty & ~self.touched) | (self.hole_rims() if self.opened.any() else False)
            opened = ndimage.binary_dilation(seen, structure=np.ones((3, 3), dtype=bool))[rows, cols] & blocked
            failed = np.array([r not in EXPLAINING for r in reason], dtype=bool)
            reason[opened & failed] = HOLE
        reason[self.tilt(rows, cols) > max_tilt_rad] = "tilt"
        if math.isfinite(table_z_m):
            reason[self.z_max[rows, cols] <= table_z_m + table_clearance_m] = "table"
        reason[self.count[rows, cols] == 0] = GAP
        return rows, cols, out, reason

    def remainder(self, max_tilt_rad: float, table_z_m: float = math.nan, table_clearance_m: float = 0.0
                  ) -> dict[str, float]:
        """Length (m) of the frontier by reason (see :meth:`classify`; "" for the open part): a
        frontier cell counts one cell edge."""
        _, _, _, reason = self.classify(max_tilt_rad, table_z_m, table_clearance_m)
        names, counts = np.unique(reason.astype(str), return_counts=True)
        return {str(n): float(k) * self.cell_m for n, k in zip(names, counts)}

    def normal_at(self, row: int, col: int) -> np.ndarray:
        """Mean outward normal (unit, world) of the samples in cell ``(row, col)`` (+z where it
        has none)."""
        n = self.normal_sum[row, col]
        norm = float(np.linalg.norm(n))
        return n / norm if norm > 0 else np.array([0.0, 0.0, 1.0])

    def unblock(self, centre_xy, radius_m: float) -> None:
        """Clear the blocks of the cells within ``radius_m`` (m) of ``centre_xy`` (world xy), in
        every direction: the surface there has been reached another way."""
        rr, cc = self.disc(centre_xy, radius_m)
        self.blocked[rr, cc] = False
        self.cause[rr, cc] = -1
        self.closed[rr, cc] = -1

    def close(self, centre_xy, radius_m: float, cause: str) -> None:
        """Block the cells within ``radius_m`` (m) of ``centre_xy`` (world xy) in every direction,
        for ``cause``: what a re-approach found there. An explaining reason (the table, the arm's
        reach: :data:`EXPLAINING`) stays the cells' when a slide ends there later for a reason
        that explains nothing (a stall, a lost contact), which says nothing of what lies beyond;
        a later explaining end replaces it, and :meth:`unblock` or another ``close`` clears it."""
        rr, cc = self.disc(centre_xy, radius_m)
        c = self._cause_index(cause)  # a later re-approach's finding replaces an earlier one
        self.blocked[rr, cc] = True
        self.cause[rr, cc] = c
        self.closed[rr, cc] = c if cause in EXPLAINING else -1

    def mean_normal(self, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
        """Mean outward normal (unit, world, ``(k, 3)``) of the samples in the cells ``(rows,
        cols)``; NaN where untouched or outside the grid."""
        rows, cols = np.asarray(rows, dtype=int), np.asarray(cols, dtype=int)
        inside = (rows >= 0) & (rows < self.n) & (cols >= 0) & (cols < self.n)
        out = np.full((len(rows), 3), np.nan)
        s = self.normal_sum[rows[inside], cols[inside]]
        with np.errstate(invalid="ignore", divide="ignore"):
            out[inside] = s / np.linalg.norm(s, axis=-1, keepdims=True)
        return out

    def mark_bridged(self, a: np.ndarray, b: np.ndarray, half_width_m: float, end_m: float = 0.005) -> int:
        """Mark the cells between two contacts a flat pad rested on at once (world points ``a``
        and ``b``, m) as :attr:`hollow`: those within ``half_width_m`` of the segment from ``a``
        to ``b``, farther than ``end_m`` from either end along it. Returns how many cells."""
        a, b = np.asarray(a, dtype=float)[:2], np.asarray(b, dtype=float)[:2]
        length = float(np.linalg.norm(b - a))
        if not length > 2 * end_m:
            return 0
        u = (b - a) / length
        lo = self.cell_of((np.minimum(a, b) - half_width_m)[None, :])[0]
        hi = self.cell_of((np.maximum(a, b) + half_width_m)[None, :])[0] + 1
        lo, hi = np.maximum(lo, 0), np.minimum(hi, self.n)
        if np.any(hi <= lo):
            return 0
        rows, cols = np.mgrid[lo[0]:hi[0], lo[1]:hi[1]]
        d = self.centre_of(rows.ravel(), cols.ravel()) - a
        along = d @ u
        across = np.abs(d @ np.array([-u[1], u[0]]))
        inside = (along > end_m) & (along < length - end_m) & (across <= half_width_m)
        self.hollow[rows.ravel()[inside], cols.ravel()[inside]] = True
        return int(inside.sum())

    def mark_empty(self, xy: np.ndarray, opened: bool = False) -> None:
        """Mark the untouched cells at world xy points ``(k, 2)`` (m) as :attr:`empty`; with
        ``opened``, as found open by a probe of a hole too (:attr:`opened`)."""
        rc = self.cell_of(np.asarray(xy, dtype=float).reshape(-1, 2))
        rc = rc[np.all((rc >= 0) & (rc < self.n), axis=1)]
        self.empty[rc[:, 0], rc[:, 1]] = True
        if opened:
            self.opened[rc[:, 0], rc[:, 1]] = True
        untouched = ~self.touched
        self.empty &= untouched
        self.opened &= untouched

    def hole_rims(self) -> np.ndarray:
        """``(n, n)`` bool: the untouched cells, not seen :attr:`empty`, within
        :data:`HOLE_RIM_M` and a cell of cells a probe found open (:attr:`opened`): the band a
        probe leaves along the rim of a hole, which the estimate still counts as untouched and
        across which a failed attempt at the rim faces the hole (:data:`HOLE`)."""
        out = np.zeros((self.n, self.n), dtype=bool)
        reach = HOLE_RIM_M + self.cell_m
        margin = int(math.ceil(reach / self.cell_m)) + 1
        rows, cols = self._window()
        w = (slice(max(rows.start - margin, 0), min(rows.stop + margin, self.n)),
             slice(max(cols.start - margin, 0), min(cols.stop + margin, self.n)))
        seen = self.opened[w] & self.empty[w]
        if not seen.any():
            return out
        near = ndimage.distance_transform_edt(~seen) * self.cell_m <= reach
        out[w] = near & ~self.empty[w] & ~self._touched(self.count[w])
        return out

    def longest_run_m(self, rows: np.ndarray, cols: np.ndarray) -> float:
        """Length (m, in cell edges) of the longest run among the cells ``rows, cols``: the most
        cells of them connected an 8-neighbour apart (0 for none)."""
        if not len(rows):
            return 0.0
        cells = np.zeros((self.n, self.n), dtype=bool)
        cells[rows, cols] = True
        labels, _ = ndimage.label(cells, structure=np.ones((3, 3), dtype=bool))
        return float(np.bincount(labels[rows, cols]).max()) * self.cell_m

    def touched_area(self) -> float:
        """Area (m², in the table plane) of the touched cells."""
        return float(np.count_nonzero(self.touched)) * self.cell_m**2
