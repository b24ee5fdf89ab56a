"""Probes into a valley the flat pad bridges: where to lower the pad's corner, and how.

A flat pad bridges a hollow narrower than itself (a valley,
:meth:`~tactile_bt.contacts.frontier_map.FrontierMap.valleys`) and cannot tell whether it holds
surface it left untouched (a bowl's floor) or only the table seen through it (a ring's hole).
Tilted steeply, corner first, the pad reaches down into it: a corner that comes near the table
touching nothing at points spread over the valley finds it open there. :func:`probe_points`
spreads such points over each valley (its middle, and a ring 6 mm inside its edge), and
:func:`corner_first` finds the tilted pose that lowers the corner furthest at a point without
any part of the pad coming near the touched surface. By the edge, a corner that cannot get near
the table may still tell the wall under the rim: :func:`below_rim_z` is how low it must come for
that wall to be steeper than the pad may tilt, and :func:`steep_rim_cells` which cells of the
band a probe leaves along an open hole's rim the corners that came that low show to hold no
surface within the pad's tilt. Pure geometry: no time, no robot, no tree.

Layer: contacts.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation

from tactile_bt.contacts.frontier_map import HOLE_RIM_M

__all__ = ["probe_points", "corner_first", "pad_rotation", "least_turn", "below_rim_z", "steep_rim_cells"]

#: The yaws (rad) and the tilts (rad, below the largest) a corner-first pose is searched over.
_YAWS = np.radians(np.arange(0.0, 360.0, 15.0))
_TILT_STEPS = np.radians([0.0, 10.0, 20.0])
#: Spacing (m) of the points of the pad checked against the touched surface.
_PAD_STEP_M = 0.004


def probe_points(m, mask: np.ndarray, most: int = 5, inside_m: float = 0.006, rim_m: float = HOLE_RIM_M,
                 min_valley_m2: float = 2e-4) -> list[dict]:
    """Points to probe in each valley of ``mask`` (``(n, n)`` bool over the grid of the map
    ``m``) of at least ``min_valley_m2`` (m²): the cell farthest from the touched area, then up
    to ``most - 1`` cells ``inside_m`` (m) inside the valley's edge (or half as far as the
    first, if less), each as far from the others as can be, in turn round the first.

    Returns one dict per valley: ``centre`` (world xy, m), ``points`` ``(k, 2)`` (world xy, m),
    ``inside_m``, how far (m) the points but the first lie inside the edge, ``cells`` ``(j, 2)``,
    the world xy (m) of the valley's cells farther than ``rim_m`` from its edge (those a probe
    open at every point marks empty; the band along the rim, where the wall under a rim may be,
    stays the valley's), and ``area_m2``, the valley's area."""
    labels, n = ndimage.label(mask)
    out = []
    for k in range(1, n + 1):
        valley = labels == k
        area = float(np.count_nonzero(valley)) * m.cell_m ** 2
        if area < min_valley_m2:
            continue
        depth = ndimage.distance_transform_edt(valley)
        rows, cols = np.nonzero(valley)
        d = depth[rows, cols]
        chosen = [int(np.argmax(d))]
        ring_depth = min(inside_m / m.cell_m, 0.5 * d.max())
        ring = np.flatnonzero(np.abs(d - ring_depth) <= 0.75)
        while len(chosen) < most and len(ring):
            gap = np.min(np.hypot(rows[ring, None] - rows[chosen], cols[ring, None] - cols[chosen]), axis=1)
            best = int(np.argmax(gap))
            if gap[best] < 2.0:
                break
            chosen.append(int(ring[best]))
        xy = m.centre_of(rows, cols)
        # the others in turn round the first, from beyond the widest gap between them: the pad
        # tilts towards the middle from each, and turns the least from one to the next
        around = np.arctan2(*(xy[chosen[1:]] - xy[chosen[0]]).T[::-1])
        order = np.argsort(around)
        if len(order) > 1:
            gaps = np.diff(np.concatenate((around[order], [around[order][0] + 2 * math.pi])))
            order = np.roll(order, -(int(np.argmax(gaps)) + 1))
        chosen = [chosen[0]] + [chosen[1 + int(j)] for j in order]
        out.append({"centre": xy[chosen[0]], "points": xy[chosen], "inside_m": float(ring_depth * m.cell_m),
                    "cells": xy[d * m.cell_m > rim_m],
                    "area_m2": area})
    return out


def pad_rotation(size_m: tuple[float, float], yaw: float, tilt: float) -> np.ndarray:
    """The rotation (world, 3×3) of a pad ``size_m`` (m) lowered corner first: its diagonal
    from the corner at sensor ``(-w/2, -h/2)`` rising at ``tilt`` (rad) from the table plane
    towards the world xy direction ``yaw`` (rad), its other diagonal level and its sensor z
    (into the surface) pointing down."""
    w, h = size_m
    level = np.diag([1.0, -1.0, -1.0])  # sensor z down; the diagonal lies along world (w, -h)
    turn = Rotation.from_euler("z", yaw - math.atan2(-h, w)).as_matrix() @ level
    d = np.array([math.cos(yaw), math.sin(yaw), 0.0])
    hinge = np.cross([0.0, 0.0, 1.0], d)  # about it, a negative angle raises the diagonal's far end
    return Rotation.from_rotvec(-tilt * hinge).as_matrix() @ turn


def least_turn(R: np.ndarray, current: np.ndarray, size_m: tuple[float, float]) -> np.ndarray:
    """``R`` (world, 3×3), or ``R`` turned about the pad's normal by the quarter turns (half
    turns for a pad that is not square) under which the pad lies the same: the one nearest
    ``current``, so that probe after probe the wrist does not wind up."""
    w, h = size_m
    step = math.pi / 2 if abs(w - h) < 1e-9 else math.pi
    turns = [R @ Rotation.from_rotvec([0.0, 0.0, k * step]).as_matrix() for k in range(int(round(2 * math.pi / step)))]
    return min(turns, key=lambda Rk: float(np.linalg.norm(Rotation.from_matrix(Rk @ current.T).as_rotvec())))


def corner_first(m, xy: np.ndarray, size_m: tuple[float, float], max_tilt_rad: float, clearance_m: float,
                 floor_z: float, near: np.ndarray | None = None, deep_enough_z: float = -math.inf
                 ) -> tuple[np.ndarray, float] | None:
    """The pose that lowers the pad's corner furthest at world ``xy`` (m) with every part of
    the pad at least ``clearance_m`` above the touched surface (the map ``m``'s highest sample
    per cell) and the corner no lower than ``floor_z`` (world z, m): ``(R, corner_z)``, the
    pad's rotation and the corner's height; None when no pose keeps the corner below the
    touched surface's highest point. Given the rotation ``near`` (world, 3×3), of the poses that
    lower the corner as far, or to ``deep_enough_z`` (world z, m) or below, the one that turns
    the pad least from it (:func:`least_turn`), turned so."""
    w, h = size_m
    u, v = np.meshgrid(np.arange(0.0, w + 1e-9, _PAD_STEP_M), np.arange(0.0, h + 1e-9, _PAD_STEP_M))
    local = np.column_stack((u.ravel() - 0.5 * w, v.ravel() - 0.5 * h, np.zeros(u.size)))
    corner = np.array([-0.5 * w, -0.5 * h, 0.0])
    heights = np.where(m.count > 0, m.z_max, -np.inf)
    top = float(np.max(heights))
    found = []
    for tilt in max_tilt_rad - _TILT_STEPS:
        if tilt <= 0:
            continue
        for yaw in _YAWS:
            R = pad_rotation(size_m, float(yaw), float(tilt))
            offset = (local - corner) @ R.T  # from the corner
            rc = m.cell_of(np.asarray(xy)[None, :2] + offset[:, :2])
            inside = np.all((rc >= 0) & (rc < m.n), axis=1)
            under = np.full(len(offset), -np.inf)
            under[inside] = heights[rc[inside, 0], rc[inside, 1]]
            z = max(float(np.max(under + clearance_m - offset[:, 2])), floor_z)
            if z < top:
                found.append((R, z))
    if not found:
        return None
    lowest = min(z for _, z in found)
    if near is None:
        return next((R, z) for R, z in found if z == lowest)
    turned = [(least_turn(R, near, size_m), z) for R, z in found if z <= max(lowest, deep_enough_z)]
    return min(turned, key=lambda rz: float(np.linalg.norm(Rotation.from_matrix(rz[0] @ near.T).as_rotvec())))


def below_rim_z(m, xy: np.ndarray, inside_m: float, max_tilt_rad: float) -> float:
    """The height (world z, m) a corner lowered at world ``xy``, ``inside_m`` (m) inside the
    edge of a valley of the map ``m``, must come down to touching nothing for the surface under
    the rim there to fall away steeper than ``max_tilt_rad`` (rad) from the horizontal: the
    highest sample of the touched cells within ``inside_m`` and two cells of ``xy``, less
    ``inside_m · tan(max_tilt_rad)``; -inf where no touched cell is that near. A corner that
    touches above it found the wall under the rim within the pad's tilt: surface the flat pad
    bridged and left."""
    rr, cc = m.disc(np.asarray(xy, dtype=float), inside_m + 2 * m.cell_m)
    z = m.z_max[rr, cc][m.count[rr, cc] > 0]
    if not len(z):
        return -math.inf
    return float(np.max(z)) - inside_m * math.tan(max_tilt_rad)


def steep_rim_cells(m, points_xy: np.ndarray, reached_z: np.ndarray, max_tilt_rad: float, along_m: float,
                    near_m: float = 0.03) -> np.ndarray:
    """World xy (m, ``(k, 2)``) of the cells of the band along the rims of open holes (the map
    ``m``'s :meth:`~tactile_bt.contacts.frontier_map.FrontierMap.hole_rims`) that the corner of
    a probe shows to hold no surface the pad could lie on: those within ``along_m`` (m) of a
    point (``points_xy``, world, m) where the corner came down to ``reached_z`` (world z, m)
    touching nothing, at or below :func:`below_rim_z` for the point's distance from the touched
    area. The wall under the rim there falls away, on average between the rim and the point,
    steeper than ``max_tilt_rad`` (rad): along the rim it is taken to do so as far as
    ``along_m``. The cells next to the touched area (an 8-neighbour apart) are not among them: a
    rounded rim steepens gradually, and just beyond the touched edge it may still lie within the
    pad's tilt where on average it falls away steeper. Points farther than ``near_m`` (m) from
    every touched cell show nothing."""
    rims = m.hole_rims()
    if not rims.any():
        return np.zeros((0, 2))
    touched = m.touched
    shown = []
    for xy, z in zip(np.asarray(points_xy, dtype=float).reshape(-1, 2), np.asarray(reached_z, dtype=float)):
        rr, cc = m.disc(xy, near_m)
        hit = touched[rr, cc]
        if not np.any(hit):
            continue
        inside = float(np.min(np.linalg.norm(m.centre_of(rr[hit], cc[hit]) - xy, axis=1)))
        if z <= below_rim_z(m, xy, inside, max_tilt_rad):
            shown.append(xy)
    if not shown:
        return np.zeros((0, 2))
    rows, cols = np.nonzero(rims & ~ndimage.binary_dilation(touched, structure=np.ones((3, 3), dtype=bool)))
    cells = m.centre_of(rows, cols)
    gap = np.min(np.linalg.norm(cells[:, None, :] - np.asarray(shown)[None, :, :], axis=2), axis=1)
    return cells[gap <= along_m]
