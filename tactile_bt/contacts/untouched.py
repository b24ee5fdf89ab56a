"""What a scan leaves untouched beyond its frontier: estimates of the surface the pad did not
reach, from the map's samples (:class:`~tactile_bt.contacts.frontier_map.FrontierMap`).

- :func:`face_going_on`: which frontier cells lie on a plane face going on down to the table,
  where the table (not the surface's end) stopped a pad lying on it;
- :func:`untouched_below`: the band such a face leaves between that frontier and the table;
- :func:`untouched_beyond`: the surface taken to go on beyond frontier where something other
  than the surface stopped the pad (the arm's reach).

Each walks the surface outwards of the frontier cells as it is estimated to go on and counts the
steps no contact sample lies near: the scan figures' coverage, in the table plane. Pure geometry:
no time, no robot, no tree.

Layer: contacts.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from tactile_bt.contacts.frontier_map import FrontierMap

__all__ = ["face_going_on", "untouched_below", "untouched_beyond", "FACE_INWARD_M", "FACE_TURN_RAD"]

#: :func:`face_going_on` compares a frontier cell's mean normal with that of the cell
#: this far inwards (m), and takes the surface for a plane face when they differ by at most
#: ``FACE_TURN_RAD``: a radius of curvature above about 115 mm, more than the pad's 80 mm.
FACE_INWARD_M = 0.010
FACE_TURN_RAD = math.radians(5.0)
#: Steepest slope (rad) a walk of :func:`_walked_untouched` descends at.
_STEEPEST = math.radians(85.0)


def face_going_on(m: FrontierMap, rows: np.ndarray, cols: np.ndarray, out: np.ndarray, steep_rad: float,
                  table_z_m: float, reach_m: float = math.inf, inward_m: float = FACE_INWARD_M,
                  max_turn_rad: float = FACE_TURN_RAD) -> np.ndarray:
    """Which frontier cells ``(rows, cols)`` (outward directions ``out``, ``(k, 2)``) lie on
    a plane face that goes on down to the table at ``table_z_m`` within the pad's reach: the
    mean normal of the cell and that of the cell ``inward_m`` inwards (against ``out``)
    differ by at most ``max_turn_rad``, the face is tilted less than ``steep_rad``, and a pad
    lying on it with its contact at the cell has a corner at most ``reach_m`` away down at
    the table (the cell at most ``reach_m · sin(tilt)`` above it). Only there can the table
    have stopped a pad lying on the surface and left a part of it untouched. Where the
    surface turns (a rounded side steepening towards the table, an edge the pad rolled over,
    a level top far above the table) what lies beyond is steeper than what was touched."""
    if not len(rows) or not math.isfinite(table_z_m):
        return np.zeros(len(rows), dtype=bool)
    n, n_in = _normals_and_inwards(m, rows, cols, np.asarray(out, dtype=float), inward_m)
    with np.errstate(invalid="ignore"):
        flat = np.sum(n * n_in, axis=1) >= math.cos(max_turn_rad)  # NaN (untouched) is not
        sin_tilt = np.sqrt(np.maximum(1.0 - n[:, 2] ** 2, 0.0))
        reached = m.z_max[rows, cols] - table_z_m <= reach_m * sin_tilt
        return flat & (n[:, 2] > math.cos(steep_rad)) & reached


def untouched_below(m: FrontierMap, rows: np.ndarray, cols: np.ndarray, out: np.ndarray, table_z_m: float,
                    steep_rad: float, samples: np.ndarray, radius_m: float, reach_m: float = math.inf,
                    face: np.ndarray | None = None) -> float:
    """Estimated area (m², in the table plane) of the surface left between the frontier
    cells ``(rows, cols)`` (outward directions ``out``) and the table at ``table_z_m``, where
    a plane face goes on down to it (:func:`face_going_on`, or ``face``, its result for these
    cells when the caller has it already): the face is walked from each such cell's highest
    sample down its slope to the table, at the face's tilt, in steps of a quarter of
    ``radius_m``, and a step counts as left where no contact sample (``samples``, ``(k, 3)``,
    world, m) lies within ``radius_m`` of it (the scan figures' coverage radius); each step
    stands for a strip a cell wide, and a step another cell's walk has counted already is
    not counted again."""
    if face is None:
        face = face_going_on(m, rows, cols, out, steep_rad, table_z_m, reach_m)
    if not np.any(face):
        return 0.0
    rows, cols, out = rows[face], cols[face], np.asarray(out, dtype=float)[face]
    # walked down the face's own slope (its normal's direction in the table plane), not along the
    # frontier's outward direction, which turns cell by cell where the foot runs across the grid
    downhill = m.mean_normal(rows, cols)[:, :2]
    length = np.linalg.norm(downhill, axis=1)
    sloping = length > 1e-9
    out[sloping] = downhill[sloping] / length[sloping, None]
    tilt = np.maximum(m.tilt(rows, cols), math.radians(1.0))
    run = np.maximum(m.z_max[rows, cols] - table_z_m, 0.0) / np.tan(tilt)
    return _walked_untouched(m, rows, cols, out, run, tilt, np.zeros(len(rows)), samples, radius_m)


def untouched_beyond(m: FrontierMap, rows: np.ndarray, cols: np.ndarray, out: np.ndarray, steep_rad: float,
                     samples: np.ndarray, radius_m: float, table_z_m: float = -math.inf,
                     inward_m: float = FACE_INWARD_M) -> float:
    """Estimated area (m², in the table plane) of the surface left beyond the frontier cells
    ``(rows, cols)`` (outward directions ``out``) where something other than the surface
    stopped the pad (the arm's reach): the surface is taken to go on there, as far as its shape
    was measured inwards. It is walked ``inward_m`` outwards of each cell from its highest
    sample, descending at the cell's slope along ``out`` and steepening as the mean normal
    turned over the last ``inward_m`` inwards (a surface turning the other way is walked at its
    slope), and no further than where it passes ``steep_rad`` or the table. Steps with no
    contact sample (``samples``, world, m) within ``radius_m`` count as left, as in
    :func:`untouched_below`. How far the surface goes on beyond that is not known: the
    estimate is the least that lies there."""
    rows, cols = np.asarray(rows, dtype=int), np.asarray(cols, dtype=int)
    if not len(rows):
        return 0.0
    out = np.asarray(out, dtype=float)
    n, n_in = _normals_and_inwards(m, rows, cols, out, inward_m)

    def slope(normal: np.ndarray) -> np.ndarray:  # tilt descending along out (rad, negative: rising)
        return np.arctan2(np.sum(normal[:, :2] * out, axis=1), normal[:, 2])

    with np.errstate(invalid="ignore"):
        tilt = slope(n)
        curvature = np.maximum(np.nan_to_num(tilt - slope(n_in)), 0.0) / inward_m
    known = np.isfinite(tilt)
    rows, cols, out, tilt, curvature = rows[known], cols[known], out[known], tilt[known], curvature[known]
    run = np.full(len(rows), inward_m)
    steepening = curvature > 0
    run[steepening] = np.minimum(inward_m, np.maximum(steep_rad - tilt[steepening], 0.0) / curvature[steepening])
    run[tilt >= steep_rad] = 0.0
    return _walked_untouched(m, rows, cols, out, run, tilt, curvature, samples, radius_m, table_z_m)


def _normals_and_inwards(m: FrontierMap, rows: np.ndarray, cols: np.ndarray, out: np.ndarray,
                         inward_m: float) -> tuple[np.ndarray, np.ndarray]:
    """The mean normals of the frontier cells ``(rows, cols)`` and of the cells ``inward_m``
    inwards of them (against ``out``), ``(k, 3)`` each; NaN where untouched."""
    inner = m.cell_of(m.centre_of(rows, cols) - out * inward_m)
    return m.mean_normal(rows, cols), m.mean_normal(inner[:, 0], inner[:, 1])


def _walked_untouched(m: FrontierMap, rows: np.ndarray, cols: np.ndarray, out: np.ndarray, run: np.ndarray,
                      tilt: np.ndarray, curvature: np.ndarray, samples: np.ndarray, radius_m: float,
                      table_z_m: float = -math.inf) -> float:
    """Area (m², table plane) of the steps left on walks outwards of the cells ``(rows,
    cols)`` along ``out``: from each cell's highest sample, ``run`` (m) far in the table
    plane, descending at ``tilt + curvature · s`` (rad, rad/m) after ``s`` (m), above
    ``table_z_m``, in steps of a quarter of ``radius_m``; a step counts as left where no
    contact sample (``samples``, ``(k, 3)``, world, m) lies within ``radius_m`` of it, nor
    beneath it within ``radius_m`` across (where the surface turns steeper than the walk, a
    rounded side steepening towards the table, it lies below the walk, and was touched there),
    each a strip a cell wide, counted once however many walks pass it."""
    if not len(rows) or not np.any(run > 0):
        return 0.0
    top = m.z_max[rows, cols]
    step = radius_m / 4
    steps = np.arange(0.0, float(run.max()) + step, step)
    angle = np.clip(tilt[:, None] + curvature[:, None] * steps[None, :], -_STEEPEST, _STEEPEST)
    z = top[:, None] - np.concatenate((np.zeros((len(rows), 1)), np.cumsum(np.tan(angle[:, :-1]) * step, axis=1)),
                                      axis=1)
    walk = (steps[None, :] <= run[:, None]) & (z >= table_z_m)
    xy = m.centre_of(rows, cols)[:, None, :] + out[:, None, :] * steps[None, :, None]
    points = np.concatenate((xy, z[..., None]), axis=-1)[walk]
    across = np.broadcast_to(np.column_stack((-out[:, 1], out[:, 0]))[:, None, :], xy.shape)[walk]
    if not len(points):
        return 0.0
    samples = np.asarray(samples, dtype=float).reshape(-1, 3)
    near = samples[(samples[:, 2] <= points[:, 2].max() + radius_m)
                   & np.all(samples[:, :2] >= points[:, :2].min(axis=0) - radius_m, axis=1)
                   & np.all(samples[:, :2] <= points[:, :2].max(axis=0) + radius_m, axis=1)]
    if len(near):
        distance, _ = cKDTree(near).query(points, distance_upper_bound=1.01 * radius_m)
        left = distance > radius_m
        points, across = points[left], across[left]
    if len(near) and len(points):  # a surface steeper than the walk lies beneath it: touched there?
        pairs = cKDTree(points[:, :2]).sparse_distance_matrix(cKDTree(near[:, :2]), radius_m, output_type="ndarray")
        lower = near[pairs["j"], 2] <= points[pairs["i"], 2] + radius_m
        beneath = np.zeros(len(points), dtype=bool)
        beneath[pairs["i"][lower]] = True
        points, across = points[~beneath], across[~beneath]
    offsets = (np.arange(round(m.cell_m / step)) + 0.5) * step - 0.5 * m.cell_m
    strips = points[:, None, :2] + offsets[None, :, None] * across[:, None, :]
    keys = np.unique(np.floor(strips.reshape(-1, 2) / step).astype(np.int64), axis=0)
    return float(len(keys)) * step * step
