"""Signed-distance grids: trilinear interpolation, its continuation outside the grid, the form the
compiled pad model reads, and grids sampled from a shape's exact signed distance.

A grid is anything with ``values`` (``(n0, n1, n2)`` signed distances, m, at ``lo + h · index``
in the object frame), ``lo`` (3,), ``h`` (m), ``hi`` (3,) and ``border_min`` (the smallest value
on the grid's faces): a mesh's :class:`tactile_bt.sim.mesh_object.MeshGrid` or a
:class:`SampledGrid`. Outside the grid a point reads ``max(g(clamp(p)) - e, e + border_min)`` with
``e = |p - clamp(p)|``: both are lower bounds of the true distance, and the first joins the grid
on its faces (see :mod:`tactile_bt.sim.mesh_object`, step 6).

A shape without a compiled form of its own (:meth:`tactile_bt.sim.objects.SimObject.kernel_shape`)
is evaluated by the pad model through :func:`sample_grid` of its ``local_sdf``: the kernels' mesh
path (``SHAPE_MESH``), which reads the grid with the same interpolation as :func:`interpolate`.

Layer: sim.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy import ndimage

from tactile_bt import defaults
from tactile_bt.sim import kernels

__all__ = ["SampledGrid", "sample_grid", "interpolate", "kernel_form", "MARGIN_CELLS", "MARGIN_M"]

#: Margin of a grid around the shape's bounds: this many cells plus :data:`MARGIN_M` (m).
MARGIN_CELLS = 3
MARGIN_M = 4.0e-3


@dataclass(frozen=True, eq=False)
class SampledGrid:
    """Signed distances (m) of a shape sampled on a regular grid in its own frame."""

    values: np.ndarray  # (n0, n1, n2) at lo + h * index
    lo: np.ndarray  # (3,) grid origin (m)
    h: float  # cell size (m)
    border_min: float  # smallest value on the grid's faces (m)

    @property
    def hi(self) -> np.ndarray:
        """The grid's far corner (m)."""
        return self.lo + self.h * (np.array(self.values.shape) - 1)


def grid_cell(bounds: np.ndarray, resolution: float = defaults.SHAPE_GRID_RESOLUTION_M,
              max_points: int = defaults.SHAPE_GRID_MAX_POINTS) -> float:
    """Cell size (m) of a grid over ``bounds`` (``(2, 3)``, m) plus the margin: ``resolution``, or
    coarser when that would take more than ``max_points`` points."""
    h = float(resolution)
    while True:
        span = np.asarray(bounds[1], float) - np.asarray(bounds[0], float) + 2 * (MARGIN_CELLS * h + MARGIN_M)
        if np.prod(np.ceil(span / h) + 1) <= max_points:
            return h
        h *= 1.25


def sample_grid(local_sdf: Callable[[np.ndarray], np.ndarray], bounds: np.ndarray, h: float) -> SampledGrid:
    """``local_sdf`` (``(N, 3)`` points → ``(N,)`` m) on a grid of cell ``h`` (m) covering the
    ``(2, 3)`` box ``bounds`` plus the margin."""
    bounds = np.asarray(bounds, dtype=float)
    if bounds.shape != (2, 3) or not np.all(np.isfinite(bounds)):
        raise ValueError(f"a signed-distance grid needs finite (2, 3) bounds, got {bounds!r}")
    margin = MARGIN_CELLS * h + MARGIN_M
    lo = bounds[0] - margin
    shape = tuple(int(n) for n in np.ceil((bounds[1] + margin - lo) / h).astype(int) + 1)
    axes = [lo[k] + h * np.arange(shape[k]) for k in range(3)]
    values = np.empty(shape)
    gy, gz = np.meshgrid(axes[1], axes[2], indexing="ij")
    plane = np.column_stack((np.zeros(gy.size), gy.ravel(), gz.ravel()))
    for i, x in enumerate(axes[0]):  # a plane at a time: memory stays at one plane of points
        plane[:, 0] = x
        values[i] = np.asarray(local_sdf(plane), dtype=float).reshape(shape[1], shape[2])
    border = min(values[0].min(), values[-1].min(), values[:, 0].min(), values[:, -1].min(),
                 values[:, :, 0].min(), values[:, :, -1].min())
    values.setflags(write=False)
    return SampledGrid(values=values, lo=lo, h=float(h), border_min=float(border))


def interpolate(grid, points: np.ndarray) -> np.ndarray:
    """Signed distance (m) of ``(N, 3)`` object-frame points read from ``grid``: trilinear inside,
    the conservative continuation outside (the kernels' ``local_sdf`` of ``SHAPE_MESH``)."""
    lo, hi = grid.lo, grid.hi
    coords = ((points - lo) * (1.0 / grid.h)).T
    # mode="nearest" reads the clamped point outside the grid
    v = ndimage.map_coordinates(grid.values, coords, order=1, mode="nearest", prefilter=False)
    outside = np.maximum(lo - points, 0.0) + np.maximum(points - hi, 0.0)
    d_out = np.sqrt(np.einsum("ij,ij->i", outside, outside))
    off = d_out > 0
    if off.any():
        v[off] = np.maximum(v[off] - d_out[off], d_out[off] + grid.border_min)
    return v


def kernel_form(grid) -> tuple[int, list, np.ndarray]:
    """``grid`` as the compiled pad model reads it (:func:`tactile_bt.sim.kernels.pack_objects`)."""
    return kernels.SHAPE_MESH, [*grid.lo, 1.0 / grid.h, *grid.hi, grid.border_min], grid.values
