"""Any closed triangle mesh as a simulated object, through a precomputed signed-distance grid.

The grid is built once per ``(file, scale, resolution)`` (and the file's modification time) and
kept in memory, so several objects, worlds and missions share it; the object then answers
:meth:`MeshObject.sdf` by trilinear interpolation (``scipy.ndimage.map_coordinates``,
``order=1``), microseconds per point.

How the grid is built (about 1 s for the shipped ``sim/meshes/unknown_object.ply``, 20 480
triangles, 136 × 96 × 49 points at the default 1 mm; ``MeshGrid.build_time_s`` records it).
``h`` is the cell size, ``r = h·√3/2`` half a cell's diagonal.

1. **Sign.** Inside/outside of every grid point by ray parity: for each of the three axes every
   triangle is rasterised onto the grid's columns along that axis, its crossing is counted, and
   a cumulative sum along each column gives the number of crossings before each point. The three
   parities vote (2 of 3), so a ray that grazes an edge cannot flip a column. The mesh must be
   closed (watertight); an open mesh is an error.
2. **Exact shell.** The triangles are split into pieces no longer than 2 cells, and every grid
   point within a cell of a piece's bounding box gets its exact point–triangle distance to that
   piece (minimum over pieces). Every grid point within ``h`` of the surface is covered, so the
   values ``<= h`` are exact.
3. **Near band** (up to :data:`NEAR_M` from the shell, both sides): the exact distance to the
   piece whose centroid is nearest (k-d tree). That is never below the true distance and in
   practice equal to it (measured: within 0.01 mm beyond a cell from the surface).
4. **Deeper inside**: the distance to the piece nearest to the closest shell point (Euclidean
   feature transform); never below the true depth, off by a few tenths of a cell at most, near
   the medial axis.
5. **Far outside**: the larger of two lower bounds of the true distance: ``e - r``, with ``e``
   the distance to the exact shell (every surface point has a shell grid point within ``r``),
   and ``g(v) - |p - v|`` with ``v`` the nearest grid point of the near band, which joins the
   band without a step. Conservative and continuous, but up to about ``h + r`` below the true
   distance: only the sensor's broad phase looks this far, and a low value there only keeps a
   tactel it could have skipped.
6. **Outside the grid** (a margin of :data:`MARGIN_CELLS` cells plus :data:`MARGIN_M` around the
   mesh): ``max(g(clamp(p)) - |p - clamp(p)|, |p - clamp(p)| + m)`` with ``g`` the grid and ``m``
   the smallest value on its faces. Both terms are lower bounds of the true distance and the
   first equals the grid on its faces, so the field stays continuous and conservative (its slope
   can reach √2 there, as the grid's value varies along the face).

Accuracy of :meth:`MeshObject.sdf` between grid points: the trilinear interpolant is off by
``O(h² κ)`` on curved surfaces (micrometres at 1 mm for radii of centimetres) and by up to about
0.1–0.3 mm within a cell of a sharp crease or of the medial axis, where its slope can also exceed
1 by a little. The sensor's broad phase (it keeps tactels whose centre reads less than half a
tactel diagonal plus 2 mm) only reads the exact shell and the near band, which
:data:`NEAR_M` makes wider than that reach.

``trimesh`` is imported only when a mesh file is loaded.

Layer: sim.
"""

from __future__ import annotations

import functools
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from tactile_bt.errors import MeshError
from tactile_bt.sim import sdf_grid
from tactile_bt.sim.objects import SimObject
from tactile_bt.sim.registry import ObjectSource, register_shape
from tactile_bt.sim.schema import POSITIVE, STR
from tactile_bt.sim.sdf_grid import MARGIN_CELLS, MARGIN_M

__all__ = ["MeshObject", "MeshGrid", "MeshError", "mesh_grid", "build_grid", "load_mesh", "point_triangle_distance",
           "NEAR_M", "MARGIN_CELLS", "MARGIN_M"]

# The grid's margin around the mesh's bounds, MARGIN_CELLS cells plus MARGIN_M, is that of every
# signed-distance grid (tactile_bt.sim.sdf_grid).
#: Beyond the exact shell, the nearest piece's distance up to here from the shell (both sides);
#: deeper inside the propagated piece's, farther outside lower bounds. More than the pad's reach
#: (half a tactel diagonal) plus the sensor's broad-phase margin, so that the broad phase's
#: decisions only read (near-)exact values.
NEAR_M = 6.0e-3
#: Pieces of the surface no longer than this many cells.
SUBDIVIDE_CELLS = 2.0
#: Refuse grids larger than this (memory and load time).
MAX_GRID_POINTS = 3.0e7


@dataclass(frozen=True, eq=False)
class MeshGrid:
    """A signed-distance grid of a mesh (all in the mesh's own frame, metres)."""

    values: np.ndarray  # (nx, ny, nz) signed distance at lo + h * index
    lo: np.ndarray  # (3,) grid origin
    h: float  # cell size
    mesh_bounds: np.ndarray  # (2, 3) AABB of the (scaled) vertices
    border_min: float  # smallest grid value on the grid's faces
    vertices: np.ndarray = field(repr=False)  # (V, 3) scaled vertices
    faces: np.ndarray = field(repr=False)  # (F, 3)
    build_time_s: float = 0.0

    @property
    def hi(self) -> np.ndarray:
        return self.lo + self.h * (np.array(self.values.shape) - 1)


# ----------------------------------------------------------------------------- geometry


def point_triangle_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Euclidean distance of points ``p`` to triangles ``(a, b, c)`` (all ``(N, 3)``, row-wise):
    the projection onto the triangle's plane if it falls inside, else the nearest edge."""
    tris = _Triangles(np.stack((a, b, c), axis=1))
    return tris.distance(np.asarray(p, dtype=float), np.arange(len(tris.tris)))


def _parity_inside(tri_g: np.ndarray, shape: tuple, axis: int) -> np.ndarray:
    """Inside (odd number of crossings) of every grid point along rays parallel to ``axis``.

    ``tri_g``: (F, 3, 3) triangle vertices in grid units. The columns are shifted by a tiny
    irrational fraction of a cell so that rays do not pass exactly through vertices or edges.
    """
    a = axis
    b, c = (a + 1) % 3, (a + 2) % 3
    eps_b, eps_c = 1.2345e-7 * np.sqrt(2.0), 0.9876e-7 * np.sqrt(3.0)
    tb, tc, ta = tri_g[:, :, b], tri_g[:, :, c], tri_g[:, :, a]
    nb, nc, na = shape[b], shape[c], shape[a]
    j0 = np.clip(np.ceil(tb.min(axis=1) - eps_b), 0, nb).astype(np.int64)
    j1 = np.clip(np.floor(tb.max(axis=1) - eps_b), -1, nb - 1).astype(np.int64)
    k0 = np.clip(np.ceil(tc.min(axis=1) - eps_c), 0, nc).astype(np.int64)
    k1 = np.clip(np.floor(tc.max(axis=1) - eps_c), -1, nc - 1).astype(np.int64)
    nj = np.maximum(j1 - j0 + 1, 0)
    nk = np.maximum(k1 - k0 + 1, 0)
    count = nj * nk
    total = int(count.sum())
    crossings = np.zeros((na + 1) * nb * nc, dtype=np.int64)
    if total:
        tri = np.repeat(np.arange(len(tri_g)), count)
        local = np.arange(total) - np.repeat(np.cumsum(count) - count, count)
        jj = j0[tri] + local // nk[tri]
        kk = k0[tri] + local % nk[tri]
        qb = jj + eps_b
        qc = kk + eps_c
        B, C, A = tb[tri], tc[tri], ta[tri]
        # edge functions of the projected triangle at the column (q_b, q_c)
        w0 = (B[:, 1] - qb) * (C[:, 2] - qc) - (B[:, 2] - qb) * (C[:, 1] - qc)
        w1 = (B[:, 2] - qb) * (C[:, 0] - qc) - (B[:, 0] - qb) * (C[:, 2] - qc)
        w2 = (B[:, 0] - qb) * (C[:, 1] - qc) - (B[:, 1] - qb) * (C[:, 0] - qc)
        s = w0 + w1 + w2
        hit = (s != 0) & (((w0 >= 0) & (w1 >= 0) & (w2 >= 0)) | ((w0 <= 0) & (w1 <= 0) & (w2 <= 0)))
        if hit.any():
            sh = s[hit]
            at = (w0[hit] * A[hit, 0] + w1[hit] * A[hit, 1] + w2[hit] * A[hit, 2]) / sh
            ia = np.clip(np.ceil(at), 0, na).astype(np.int64)
            # flat index in an array of shape (na + 1, nb, nc)
            crossings = np.bincount((ia * nb + jj[hit]) * nc + kk[hit], minlength=(na + 1) * nb * nc)
    parity = (np.cumsum(crossings.reshape(na + 1, nb, nc), axis=0)[:na] & 1).astype(bool)
    # back to (x, y, z) axis order: the array's axes are (a, b, c)
    order = np.argsort([a, b, c])
    return np.transpose(parity, order)


def _subdivide(tris: np.ndarray, max_edge: float) -> np.ndarray:
    """Split triangles into congruent sub-triangles (a regular lattice of ``m`` steps per edge)
    until no edge is longer than ``max_edge``. The union of the pieces is the triangle, so the
    distance to the pieces is the distance to the triangle."""
    longest = np.linalg.norm(tris[:, [1, 2, 0]] - tris, axis=2).max(axis=1)
    m = np.maximum(1, np.ceil(longest / max_edge)).astype(np.int64)
    out = [tris[m == 1]]
    for mi in np.unique(m[m > 1]):
        t = tris[m == mi]
        a, e0, e1 = t[:, 0], (t[:, 1] - t[:, 0]) / mi, (t[:, 2] - t[:, 0]) / mi
        i, j = (x.ravel() for x in np.meshgrid(np.arange(mi), np.arange(mi), indexing="ij"))
        ij = lambda di, dj: np.stack((i + di, j + dj), axis=-1)  # noqa: E731
        up = np.stack((ij(0, 0), ij(1, 0), ij(0, 1)), axis=1)[i + j <= mi - 1]
        down = np.stack((ij(1, 0), ij(1, 1), ij(0, 1)), axis=1)[i + j <= mi - 2]
        lattice = np.concatenate((up, down)).astype(float)  # (K, 3 corners, 2)
        pts = (a[:, None, None, :] + lattice[None, :, :, 0, None] * e0[:, None, None, :]
               + lattice[None, :, :, 1, None] * e1[:, None, None, :])
        out.append(pts.reshape(-1, 3, 3))
    return np.concatenate(out)


def _near_pairs(tris: "_Triangles", lo: np.ndarray, h: float, shape: tuple, expand: float,
                chunk: int = 262_144) -> tuple[np.ndarray, np.ndarray]:
    """Smallest exact distance of every grid point within ``expand`` cells of a triangle's
    bounding box to those triangles (``inf`` elsewhere), and the triangle that gives it."""
    g = (tris.tris - lo) / h
    top = np.array(shape) - 1
    g0 = np.clip(np.ceil(g.min(axis=1) - expand), 0, top).astype(np.int64)
    g1 = np.clip(np.floor(g.max(axis=1) + expand), 0, top).astype(np.int64)
    n = np.maximum(g1 - g0 + 1, 0)
    count = n.prod(axis=1)
    size = int(np.prod(shape))
    best = np.full(size, np.inf)
    best_tri = np.full(size, -1, dtype=np.int64)
    # triangles in groups that expand to about `chunk` pairs each
    ends = np.searchsorted(np.cumsum(count), np.arange(chunk, int(count.sum()) + chunk, chunk), side="right")
    first = 0
    for last in np.unique(np.append(np.maximum(ends, 1), len(count))):
        sel = np.arange(first, min(int(last), len(count)))
        first = max(first, int(last))
        c = count[sel]
        total = int(c.sum())
        if total == 0:
            continue
        tri = np.repeat(sel, c)
        local = np.arange(total) - np.repeat(np.cumsum(c) - c, c)
        ny, nz = n[tri, 1], n[tri, 2]
        ix = g0[tri, 0] + local // (ny * nz)
        rem = local % (ny * nz)
        iy = g0[tri, 1] + rem // nz
        iz = g0[tri, 2] + rem % nz
        d = tris.distance(lo + h * np.stack((ix, iy, iz), axis=1), tri)
        flat = (ix * shape[1] + iy) * shape[2] + iz
        np.minimum.at(best, flat, d)
        win = d <= best[flat]
        best_tri[flat[win]] = tri[win]
    return best, best_tri


def build_grid(vertices: np.ndarray, faces: np.ndarray, resolution: float) -> MeshGrid:
    """Signed-distance grid (negative inside) of a closed mesh; see the module notes."""
    import time

    start = time.perf_counter()
    h = float(resolution)
    vertices = np.asarray(vertices, dtype=float)
    faces = np.asarray(faces, dtype=np.int64)
    if vertices.ndim != 2 or vertices.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3 or not len(faces):
        raise MeshError("a mesh needs (V, 3) vertices and (F, 3) triangles")
    vmin, vmax = vertices.min(axis=0), vertices.max(axis=0)
    margin = MARGIN_CELLS * h + MARGIN_M
    lo = vmin - margin
    shape = tuple(int(n) for n in np.ceil((vmax + margin - lo) / h).astype(int) + 1)
    if np.prod(shape, dtype=float) > MAX_GRID_POINTS:
        raise MeshError(f"a {shape[0]}x{shape[1]}x{shape[2]} grid is too large: choose a coarser resolution "
                        f"than {h} m (or check the mesh's units and scale)")
    tris = vertices[faces]

    # 1. sign by ray parity along x, y and z, 2 of 3 votes
    tri_g = (tris - lo) / h
    votes = sum(_parity_inside(tri_g, shape, axis).astype(np.int8) for axis in range(3))
    inside = (votes >= 2).ravel()

    # 2. pieces of the surface no longer than 2 cells; exact distances of the grid points within
    #    a cell of each piece's bounding box (all points within a cell of the surface)
    small = _Triangles(_subdivide(tris, SUBDIVIDE_CELLS * h))
    dist, best_tri = _near_pairs(small, lo, h, shape, expand=1.0)
    exact = dist <= h

    # Every grid point within a cell of the surface is in the exact shell, so the distance e to
    # the shell bounds the true distance: e - r <= d <= e + h (r: half a cell's diagonal).
    r = 0.5 * np.sqrt(3.0) * h
    e, source = ndimage.distance_transform_edt(~exact.reshape(shape), sampling=h, return_indices=True)
    e = e.ravel()
    near = ~exact & (e <= NEAR_M + h)

    # 3. up to NEAR_M from the surface (both sides): the distance to the piece whose centroid is
    #    nearest (never below the true distance, at most rho above it; in practice equal or
    #    within micrometres)
    todo = np.flatnonzero(near)
    tree = cKDTree(small.centroid, balanced_tree=False, compact_nodes=False)
    grid = lo + h * np.stack(np.unravel_index(todo, shape), axis=1)
    _, nearest = tree.query(grid, k=1, workers=-1)
    dist[todo] = np.minimum(dist[todo], small.distance(grid, nearest))

    # 4. deeper inside: the distance to the triangle of the nearest point of the exact shell
    #    (never below the true distance; off by up to a few tenths of a cell near the medial axis)
    deep = np.flatnonzero(~exact & ~near & inside)
    if deep.size:
        src = np.ravel_multi_index(tuple(source.reshape(3, -1)[:, deep]), shape)
        grid = lo + h * np.stack(np.unravel_index(deep, shape), axis=1)
        dist[deep] = small.distance(grid, best_tri[src])

    # 5. far outside: two lower bounds, the larger: e - r, and the value at the nearest near
    #    point minus the distance to it (which joins the near band without a step)
    far_mask = ~exact & ~near & ~inside
    far = np.flatnonzero(far_mask)
    if far.size:
        gap, source = ndimage.distance_transform_edt(far_mask.reshape(shape), sampling=h, return_indices=True)
        src = np.ravel_multi_index(tuple(source.reshape(3, -1)[:, far]), shape)
        dist[far] = np.maximum(e[far] - r, dist[src] - gap.ravel()[far])

    values = np.where(inside, -dist, dist).reshape(shape)
    faces_min = min(values[0].min(), values[-1].min(), values[:, 0].min(), values[:, -1].min(),
                    values[:, :, 0].min(), values[:, :, -1].min())
    values.setflags(write=False)
    return MeshGrid(values=values, lo=lo, h=h, mesh_bounds=np.array([vmin, vmax]),
                    border_min=float(faces_min), vertices=vertices, faces=faces,
                    build_time_s=time.perf_counter() - start)


class _Triangles:
    """Triangles with the constants of the point–triangle distance precomputed and packed in one
    array, so that evaluating many (point, triangle) pairs gathers one row per pair."""

    def __init__(self, tris: np.ndarray) -> None:
        a, b, c = tris[:, 0], tris[:, 1], tris[:, 2]
        e0, e1 = b - a, c - a
        self.centroid = tris.mean(axis=1)
        #: farthest point of any piece from its centroid (one of its corners)
        self.rho = float(np.linalg.norm(tris - self.centroid[:, None, :], axis=2).max()) * (1 + 1e-9)
        d00 = np.einsum("ij,ij->i", e0, e0)
        d01 = np.einsum("ij,ij->i", e0, e1)
        d11 = np.einsum("ij,ij->i", e1, e1)
        denom = d00 * d11 - d01 * d01
        ok = denom > 1e-24 * np.maximum(d00 * d11, 1e-300)
        inv = np.where(ok, 1.0 / np.where(ok, denom, 1.0), 0.0)
        n = np.cross(e0, e1)
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        # columns: a(0:3) e0(3:6) e1(6:9) n(9:12) d00 d01 d11 inv ok
        self.pack = np.column_stack((a, e0, e1, n, d00, d01, d11, inv, ok.astype(float)))
        self.tris = tris

    def distance(self, p: np.ndarray, t: np.ndarray, chunk: int = 262_144) -> np.ndarray:
        """Distance of points ``p`` (N, 3) to triangles ``t`` (N indices)."""
        out = np.empty(len(p))
        for s in range(0, len(p), chunk):
            out[s:s + chunk] = self._distance(p[s:s + chunk], t[s:s + chunk])
        return out

    def _distance(self, p: np.ndarray, t: np.ndarray) -> np.ndarray:
        P = self.pack[t]
        ap = p - P[:, 0:3]
        e0, e1 = P[:, 3:6], P[:, 6:9]
        d20 = np.einsum("ij,ij->i", ap, e0)
        d21 = np.einsum("ij,ij->i", ap, e1)
        d00, d01, d11, inv = P[:, 12], P[:, 13], P[:, 14], P[:, 15]
        v = (d11 * d20 - d01 * d21) * inv
        w = (d00 * d21 - d01 * d20) * inv
        inside = (P[:, 16] > 0) & (v >= 0) & (w >= 0) & (v + w <= 1)
        out = np.abs(np.einsum("ij,ij->i", ap, P[:, 9:12]))
        rest = np.flatnonzero(~inside)
        if rest.size:
            r0 = ap[rest]
            f0, f1 = e0[rest], e1[rest]
            # edges a→b, a→c from a; b→c from b (r - e0)
            m = _segment_sq(r0, f0)
            np.minimum(m, _segment_sq(r0, f1), out=m)
            np.minimum(m, _segment_sq(r0 - f0, f1 - f0), out=m)
            out[rest] = np.sqrt(m)
        return out


def _segment_sq(r: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Squared distance of points at ``r`` (relative to a segment's start) to segments ``d``."""
    dd = np.einsum("ij,ij->i", d, d)
    u = np.clip(np.einsum("ij,ij->i", r, d) / np.where(dd > 0, dd, 1.0), 0.0, 1.0)
    q = r - u[:, None] * d
    return np.einsum("ij,ij->i", q, q)


def load_mesh(path: str | Path, scale: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (scaled, m) and faces of a closed triangle mesh file (anything trimesh reads)."""
    import trimesh

    path = Path(path)
    if not path.is_file():
        raise MeshError(f"mesh file not found: {path}")
    try:
        loaded = trimesh.load(str(path), force="mesh", process=True)
    except Exception as exc:  # trimesh raises many kinds of errors for unreadable files
        raise MeshError(f"cannot read mesh {path}: {exc}") from None
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
        raise MeshError(f"{path} holds no triangles")
    if not loaded.is_watertight:
        trimesh.repair.fill_holes(loaded)
    if not loaded.is_watertight:
        raise MeshError(f"{path} is not a closed (watertight) mesh, so inside and outside are undefined; "
                        "close its holes first")
    return np.asarray(loaded.vertices, dtype=float) * float(scale), np.asarray(loaded.faces, dtype=np.int64)


@functools.lru_cache(maxsize=16)
def _cached_grid(path: str, mtime_ns: int, scale: float, resolution: float) -> MeshGrid:
    vertices, faces = load_mesh(path, scale)
    return build_grid(vertices, faces, resolution)


def mesh_grid(path: str | Path, scale: float = 1.0, resolution: float = 1.0e-3) -> MeshGrid:
    """The signed-distance grid of a mesh file, built once per ``(file, scale, resolution)``
    (and file modification time) and then served from memory."""
    path = Path(path).resolve()
    try:
        mtime = os.stat(path).st_mtime_ns
    except OSError:
        raise MeshError(f"mesh file not found: {path}") from None
    return _cached_grid(str(path), mtime, float(scale), float(resolution))


# ----------------------------------------------------------------------------- object


@register_shape("mesh")
@dataclass(eq=False)
class MeshObject(SimObject):
    """A closed triangle mesh (STL, OBJ, PLY, … anything trimesh reads).

    Parameters
    ----------
    path : str or Path
        The mesh file; its coordinates times ``scale`` are the object frame (m). In a scene,
        relative to the scene file's directory.
    scale : float
        Factor from file units to metres (``0.001`` for a file in millimetres).
    resolution : float
        Cell size of the signed-distance grid (m).
    grid : MeshGrid, optional
        A prebuilt grid (then ``path`` is only a label).

    A shape known only by its triangles is a subclass that builds its ``grid`` with
    :func:`build_grid` (as :meth:`from_arrays` does).
    """

    schema = {"path": STR, "scale": POSITIVE, "resolution": POSITIVE}
    required = ("path",)
    example = {"path": "meshes/unknown_object.ply"}

    path: str = ""
    scale: float = 1.0
    resolution: float = 1.0e-3
    grid: MeshGrid | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.scale <= 0 or self.resolution <= 0:
            raise ValueError("mesh scale and resolution must be positive")
        if self.grid is None:
            self.grid = mesh_grid(self.path, self.scale, self.resolution)
        super().__post_init__()

    @classmethod
    def from_scene(cls, fields: dict, source: ObjectSource) -> "MeshObject":
        """A mesh object; its file is relative to the scene file's directory. Imports trimesh."""
        f = dict(fields)
        path = Path(f.pop("path")).expanduser()
        if not path.is_absolute():
            path = Path(source.scene_file).resolve().parent / path
        if not path.is_file():
            raise source.error("path", f"mesh file not found: {path}")
        try:
            return cls(path=str(path), **f)
        except MeshError as exc:
            # a grid too large is the resolution's fault (or the scale's); anything else the file's
            culprit = "resolution" if "grid is too large" in str(exc) and "resolution" in source.item.value else "path"
            raise source.error(culprit, str(exc)) from None

    @classmethod
    def from_arrays(cls, vertices, faces, resolution: float = 1.0e-3, **kwargs) -> "MeshObject":
        """A mesh object from vertex (m) and face arrays, without a file or trimesh."""
        grid = build_grid(vertices, faces, resolution)
        return cls(path="<arrays>", resolution=resolution, grid=grid, **kwargs)

    def local_bounds(self) -> np.ndarray:
        return self.grid.mesh_bounds

    def kernel_shape(self) -> tuple[int, list, np.ndarray]:
        return sdf_grid.kernel_form(self.grid)

    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        return sdf_grid.interpolate(self.grid, points)

    def surface_mesh(self):
        """The mesh's triangles as they are (not processed again)."""
        import trimesh

        return trimesh.Trimesh(np.asarray(self.grid.vertices, float), np.asarray(self.grid.faces), process=False)
