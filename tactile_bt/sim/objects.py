"""Objects of the simulated world and their contact geometry.

Every object answers :meth:`SimObject.sdf`: the signed distance (m) of world points to its
surface, negative inside; the penetration of a point is ``max(-sdf, 0)``. The signed distance
is 1-Lipschitz, which lets the pad model skip tactels that cannot touch. The contact
pressure at a point of the pad is ``k · depth`` with ``k`` the per-area stiffness of the object
in series with the pad's foam (see :mod:`tactile_bt.sim.sensor`). An object's ``stiffness``
is given in N/m, the force per metre of indentation over the reference contact area of the
paper (40 tactels, :data:`CONTACT_REFERENCE_AREA_M2`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from tactile_bt import defaults

__all__ = ["CONTACT_REFERENCE_AREA_M2", "SimObject", "Table", "Cable", "polyline_from_segments"]

#: Area (m²) over which an object's stiffness in N/m is spread to give a per-area stiffness:
#: the paper's reference contact of 40 tactels.
CONTACT_REFERENCE_AREA_M2 = 40 * defaults.TACTEL_AREA_M2


@dataclass
class SimObject:
    """Base of the simulated objects.

    Parameters
    ----------
    stiffness : float
        Contact stiffness in N/m (10² soft ball … 10⁷ rigid pen).
    friction : float
        Coulomb friction coefficient (kept for the scene schema; tangential forces are not
        simulated with an ideal mount).
    """

    stiffness: float = 1.0e6
    friction: float = 0.3

    @property
    def area_stiffness(self) -> float:
        """Stiffness per area in Pa/m."""
        return self.stiffness / CONTACT_REFERENCE_AREA_M2

    def bounds(self) -> np.ndarray:
        """``(2, 3)`` axis-aligned box ``[min, max]`` (m) outside which there is no contact."""
        raise NotImplementedError

    def sdf(self, points: np.ndarray) -> np.ndarray:
        """Signed distance (m) of each ``(N, 3)`` world point to the surface, negative inside."""
        raise NotImplementedError

    def penetration(self, points: np.ndarray) -> np.ndarray:
        """Depth (m, ≥ 0) of each ``(N, 3)`` world point inside the object."""
        return np.maximum(-self.sdf(points), 0.0)


@dataclass
class Table(SimObject):
    """The half space below ``z = height`` (m)."""

    height: float = 0.0

    def bounds(self) -> np.ndarray:
        return np.array([[-np.inf, -np.inf, -np.inf], [np.inf, np.inf, self.height]])

    def sdf(self, points: np.ndarray) -> np.ndarray:
        return points[:, 2] - self.height


def polyline_from_segments(start, heading_deg: float, segments: list[dict], step: float = 0.001) -> np.ndarray:
    """Build a planar path from straight pieces and circular arcs.

    Parameters
    ----------
    start : (2,) start point (m).
    heading_deg : initial direction, degrees from +x towards +y.
    segments : list of ``{"straight": length_m}`` or ``{"arc": {"radius": m, "angle_deg": deg}}``
        (positive angles turn left).
    step : spacing of the returned points (m).

    Returns
    -------
    (N, 2) array of points along the path.
    """
    points = [np.asarray(start, dtype=float)]
    heading = np.deg2rad(heading_deg)
    for seg in segments:
        p = points[-1]
        if "straight" in seg:
            length = float(seg["straight"])
            n = max(1, int(np.ceil(length / step)))
            s = np.linspace(0.0, length, n + 1)[1:]
            d = np.array([np.cos(heading), np.sin(heading)])
            points.extend(p + s[:, None] * d)
        elif "arc" in seg:
            radius = float(seg["arc"]["radius"])
            angle = np.deg2rad(float(seg["arc"]["angle_deg"]))
            n = max(1, int(np.ceil(abs(angle) * radius / step)))
            turn = np.sign(angle)
            centre = p + radius * np.array([np.cos(heading + turn * np.pi / 2), np.sin(heading + turn * np.pi / 2)])
            phi0 = heading - turn * np.pi / 2
            phis = phi0 + np.linspace(0.0, angle, n + 1)[1:]
            points.extend(centre + radius * np.stack((np.cos(phis), np.sin(phis)), axis=1))
            heading += angle
        else:
            raise ValueError(f"a path segment must be 'straight' or 'arc', got {seg!r}")
    return np.array(points)


@functools.lru_cache(maxsize=8)
def _lateral_distance_grid(path_bytes: bytes, n: int, cell: float, margin: float):
    """Signed lateral distance (m) of grid points to a planar path, positive on the left."""
    path = np.frombuffer(path_bytes).reshape(n, 2)
    # Dense resampling so the nearest sample's tangent describes the path locally.
    seg = np.diff(path, axis=0)
    seglen = np.hypot(seg[:, 0], seg[:, 1])
    s = np.concatenate(([0.0], np.cumsum(seglen)))
    dense_s = np.linspace(0.0, s[-1], max(2, int(np.ceil(s[-1] / 5e-4)) + 1))
    dense = np.stack((np.interp(dense_s, s, path[:, 0]), np.interp(dense_s, s, path[:, 1])), axis=1)
    tangent = np.gradient(dense, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    lo = path.min(axis=0) - margin
    hi = path.max(axis=0) + margin
    xs = np.arange(lo[0], hi[0] + cell, cell)
    ys = np.arange(lo[1], hi[1] + cell, cell)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    q = np.stack((gx.ravel(), gy.ravel()), axis=1)
    _, idx = cKDTree(dense).query(q, workers=1)
    rel = q - dense[idx]
    t = tangent[idx]
    along = t[:, 0] * rel[:, 0] + t[:, 1] * rel[:, 1]
    lateral = t[:, 0] * rel[:, 1] - t[:, 1] * rel[:, 0]
    # Beyond either end the distance is to the end point (the cable's end cap).
    beyond = ((idx == 0) & (along < 0)) | ((idx == len(dense) - 1) & (along > 0))
    lateral = np.where(beyond, np.sign(lateral + 1e-300) * np.hypot(lateral, along), lateral)
    grid = lateral.reshape(gx.shape)
    grid.setflags(write=False)
    return grid, lo, s[-1]


@dataclass
class Cable(SimObject):
    """A cable of circular cross-section lying on the table along a planar path.

    Parameters
    ----------
    path : (N, 2) array
        Centreline in the table plane (m); the ground truth for path-error metrics.
    radius : float
        Cable radius (m).
    table_height : float
        Height of the table top (m); the centreline lies at ``table_height + radius``.
    """

    path: np.ndarray = None
    radius: float = 0.003
    table_height: float = 0.0
    grid_cell: float = 0.002

    def __post_init__(self) -> None:
        self.path = np.ascontiguousarray(self.path, dtype=float)
        if self.path.ndim != 2 or self.path.shape[1] != 2 or len(self.path) < 2:
            raise ValueError("cable path must be an (N, 2) array with N >= 2")
        # Points outside the grid read its border, at least ``margin`` from the path: no contact.
        margin = 0.01 + 2 * self.grid_cell
        self._grid, self._origin, self.length = _lateral_distance_grid(
            self.path.tobytes(), len(self.path), self.grid_cell, margin
        )
        lo = self.path.min(axis=0) - self.radius
        hi = self.path.max(axis=0) + self.radius
        self._bounds = np.array([[lo[0], lo[1], self.table_height], [hi[0], hi[1], self.table_height + 2 * self.radius]])

    def bounds(self) -> np.ndarray:
        return self._bounds

    def lateral_distance(self, xy: np.ndarray) -> np.ndarray:
        """Signed horizontal distance (m) of ``(N, 2)`` points from the centreline (bilinear on a
        precomputed grid; exact for straight pieces, O(cell²·curvature) on arcs). Points off the
        grid read its border, which lies farther than any contact reaches."""
        coords = ((xy - self._origin) * (1.0 / self.grid_cell)).T
        return ndimage.map_coordinates(self._grid, coords, order=1, mode="nearest", prefilter=False)

    def sdf(self, points: np.ndarray) -> np.ndarray:
        lateral = self.lateral_distance(points[:, :2])
        dz = points[:, 2] - (self.table_height + self.radius)
        return np.sqrt(lateral * lateral + dz * dz) - self.radius

    def distance_to_centreline(self, xy: np.ndarray) -> np.ndarray:
        """Horizontal distance (m) of ``(N, 2)`` points to the true centreline (exact, for metrics)."""
        a = self.path[:-1]
        d = np.diff(self.path, axis=0)
        tree = cKDTree(self.path)
        _, idx = tree.query(xy)
        best = np.full(len(xy), np.inf)
        for k in (-2, -1, 0, 1):
            j = np.clip(idx + k, 0, len(d) - 1)
            rel = xy - a[j]
            t = np.clip(np.einsum("ij,ij->i", rel, d[j]) / np.einsum("ij,ij->i", d[j], d[j]), 0.0, 1.0)
            best = np.minimum(best, np.hypot(*(rel - t[:, None] * d[j]).T))
        return best

    def arc_position(self, xy: np.ndarray) -> np.ndarray:
        """Arc length (m) along the centreline of the point nearest to each ``(N, 2)`` point."""
        s = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(self.path, axis=0).T))))
        _, idx = cKDTree(self.path).query(xy)
        return s[idx]
