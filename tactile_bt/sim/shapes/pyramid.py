"""A square pyramid: flat faces meeting in sharp ridges and an apex.

The pyramid stands on its square base in its frame's x-y plane, the base centred on the origin,
its apex on +z. Standing on a table of height 0 it has ``position: [x, y, 0]``. Its four faces
rise at ``slope_deg`` from the base; the ridges between them (and the apex) are sharp, the case
where a flat pad sliding over one face cannot roll onto the next without lifting off.

The signed distance is exact: inside, the largest signed distance to the five face planes;
outside, the distance to the nearest of the six triangles of its surface. The pad model reads it
through a 1 mm grid (:meth:`tactile_bt.sim.objects.SimObject.kernel_shape`), which rounds the
ridges off by a fraction of a millimetre and the acute edges of the base (on the table) by up to
most of a cell.

Layer: sim.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_bt.sim.objects import SimObject
from tactile_bt.sim.registry import ShapeValueError, register_shape
from tactile_bt.sim.schema import LENGTH, Range
from tactile_bt.sim.shapes.primitives import positive

__all__ = ["Pyramid"]


def _triangle_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Distance (m) of the ``(N, 3)`` points ``p`` from the triangle ``a, b, c``: to its plane
    where they project inside it, else to the nearest of its edges."""
    n = np.cross(b - a, c - a)
    n = n / np.linalg.norm(n)
    edges = ((a, b), (b, c), (c, a))
    inside = np.ones(len(p), dtype=bool)
    nearest_edge = np.full(len(p), np.inf)
    for u, v in edges:
        inside &= (np.cross(v - u, p - u) @ n) >= 0.0
        t = np.clip((p - u) @ (v - u) / float((v - u) @ (v - u)), 0.0, 1.0)
        nearest_edge = np.minimum(nearest_edge, np.linalg.norm(p - (u + t[:, None] * (v - u)), axis=1))
    return np.where(inside, np.abs((p - a) @ n), nearest_edge)


@register_shape("pyramid")
@dataclass(eq=False)
class Pyramid(SimObject):
    """A square pyramid of base edge ``base`` (m) whose faces rise at ``slope_deg`` (degrees
    from the base plane, between 5° and 85°); its height is ``base / 2 · tan(slope)``."""

    schema = {"base": LENGTH, "slope_deg": Range(5.0, 85.0, unit="deg")}
    required = ("base", "slope_deg")
    example = {"base": 0.16, "slope_deg": 40.0}

    base: float = 0.16
    slope_deg: float = 40.0

    def __post_init__(self) -> None:
        self.base = positive("pyramid base", self.base)
        if not 5.0 <= float(self.slope_deg) <= 85.0:
            raise ShapeValueError("slope_deg", f"the faces' slope must be between 5 and 85 degrees, got {self.slope_deg!r}")
        self.slope_deg = float(self.slope_deg)
        super().__post_init__()

    @property
    def height(self) -> float:
        """Height of the apex above the base (m)."""
        return 0.5 * self.base * math.tan(math.radians(self.slope_deg))

    def _planes(self) -> tuple[np.ndarray, np.ndarray]:
        """Outward unit normals ``(5, 3)`` of the faces (four sides, then the base) and their
        offsets: a point p is inside where ``normals @ p <= offsets`` for all five."""
        s, c = math.sin(math.radians(self.slope_deg)), math.cos(math.radians(self.slope_deg))
        normals = np.array([[s, 0, c], [-s, 0, c], [0, s, c], [0, -s, c], [0, 0, -1.0]])
        offsets = np.array([self.height * c] * 4 + [0.0])
        return normals, offsets

    def local_bounds(self) -> np.ndarray:
        a = 0.5 * self.base
        return np.array([[-a, -a, 0.0], [a, a, self.height]])

    def _corners(self) -> np.ndarray:
        a = 0.5 * self.base
        return np.array([[-a, -a, 0.0], [a, -a, 0.0], [a, a, 0.0], [-a, a, 0.0], [0.0, 0.0, self.height]])

    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        normals, offsets = self._planes()
        planes = np.max(points @ normals.T - offsets, axis=1)
        outside = planes > 0.0
        if np.any(outside):
            corners = self._corners()
            triangles = corners[[[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4], [0, 2, 1], [0, 3, 2]]]
            p = points[outside]
            planes[outside] = np.min([_triangle_distance(p, *t) for t in triangles], axis=0)
        return planes

    def surface_mesh(self):
        import trimesh

        return trimesh.convex.convex_hull(self._corners())
