"""Objects of the simulated world and their contact geometry.

Every object answers :meth:`SimObject.sdf`: the signed distance (m) of world points to its
surface, negative inside; the penetration of a point is ``max(-sdf, 0)``. The signed distance
is 1-Lipschitz (exact for the primitives), which lets the pad model skip tactels that cannot
touch. The contact pressure at a point of the pad is ``k · depth`` with ``k`` the per-area
stiffness of the object in series with the pad's foam (see :mod:`tactile_bt.sim.pad`). An
object's ``stiffness`` is given in N/m, the force per metre of indentation over the reference
contact area of the paper (40 tactels, :data:`CONTACT_REFERENCE_AREA_M2`). This per-area
(Winkler) model makes soft objects deform: the deeper the pad presses, the larger the area
that touches, so a soft ball (10² N/m) shows a wide contact and a rigid pen (10⁷ N/m) a line.

Every object has a world pose ``pose`` (4×4, the object frame in the world); a subclass
describes its shape in its own frame (:meth:`SimObject.local_sdf`, :meth:`SimObject.local_bounds`)
and the base class transforms points into that frame. :meth:`SimObject.moved` returns a copy
displaced in the world (scene events).

Shapes register under their scene ``type`` (:mod:`tactile_bt.sim.registry`, which states what a
shape provides; this base gives the defaults): :class:`Table` and :class:`Cable` here, the
primitives and the torus in :mod:`tactile_bt.sim.shapes`, triangle meshes in
:mod:`tactile_bt.sim.mesh_object` (which imports trimesh only when a mesh is loaded).

Layer: sim.
"""

from __future__ import annotations

import copy
import functools
from dataclasses import dataclass, field
from typing import Any, ClassVar, Mapping

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from tactile_bt import defaults
from tactile_bt.sim import kernels, sdf_grid
from tactile_bt.sim.cable_path import centreline_from_scene, polyline_from_segments
from tactile_bt.sim.registry import ObjectSource, register_shape
from tactile_bt.sim.schema import ANGLE_DEG, COORD, LIST, ListOf, Range

__all__ = ["CONTACT_REFERENCE_AREA_M2", "SimObject", "Table", "Cable", "polyline_from_segments", "object_pose"]

#: Area (m²) over which an object's stiffness in N/m is spread to give a per-area stiffness:
#: the paper's reference contact of 40 tactels of 25 mm², 1e-3 m². It defines the unit of the
#: scenes' ``stiffness`` (N/m over this area), so it is a constant of the paper's pad and does
#: not follow the scene's ``sensor.pitch``: the same object is as stiff under any pad.
CONTACT_REFERENCE_AREA_M2 = 40 * defaults.TACTEL_AREA_M2


def object_pose(position=(0.0, 0.0, 0.0), rpy_deg=(0.0, 0.0, 0.0)) -> np.ndarray:
    """4×4 pose from a position (m) and extrinsic x-y-z angles (degrees), as in the scene files
    (the same convention as the mount's ``rpy_deg``)."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_euler("xyz", np.asarray(rpy_deg, dtype=float), degrees=True).as_matrix()
    T[:3, 3] = np.asarray(position, dtype=float)
    return T


@dataclass(eq=False)
class SimObject:
    """Base of the simulated objects.

    Parameters
    ----------
    stiffness : float
        Contact stiffness in N/m (10² soft ball … 10⁷ rigid pen).
    friction : float
        Coulomb friction coefficient (kept for the scene schema; tangential forces are not
        simulated with an ideal mount).
    pose : (4, 4) array, keyword only
        The object frame in the world (default identity). See :func:`object_pose`.

    Objects compare by identity (their fields hold arrays). A subclass registered as a scene
    ``type`` (:func:`tactile_bt.sim.registry.register_shape`) states its scene keys in the class
    attributes below (see :class:`tactile_bt.sim.registry.Shape`).
    """

    #: Scene ``type`` (set by the registry), the shape's own scene keys and their kinds, the keys
    #: a scene must give, a typical object in scene form, the keys that move it.
    type_name: ClassVar[str] = ""
    schema: ClassVar[Mapping[str, Any]] = {}
    required: ClassVar[tuple[str, ...]] = ()
    example: ClassVar[Mapping[str, Any]] = {}
    move_hint: ClassVar[str] = "position"

    stiffness: float = 1.0e6
    friction: float = 0.3
    pose: np.ndarray | None = field(default=None, kw_only=True, repr=False)

    def __post_init__(self) -> None:
        self._set_pose(self.pose)

    def _set_pose(self, pose) -> None:
        T = np.eye(4) if pose is None else np.array(pose, dtype=float)
        if T.shape != (4, 4) or not np.all(np.isfinite(T)):
            raise ValueError(f"pose must be a finite 4x4 transform, got {pose!r}")
        R = T[:3, :3]
        if not np.allclose(R.T @ R, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
            raise ValueError("pose: the rotation part must be a proper rotation matrix")
        self.pose = T
        self._R = np.ascontiguousarray(R)
        self._t = T[:3, 3].copy()
        #: Identity pose: points are used as they are (no transform on the hot path).
        self._identity = bool(np.array_equal(T, np.eye(4)))
        self._world_bounds = None

    # ------------------------------------------------------------------ shape (object frame)
    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        """Signed distance (m) of ``(N, 3)`` points given in the object frame."""
        raise NotImplementedError

    @classmethod
    def from_scene(cls, fields: dict, source: ObjectSource) -> "SimObject":
        """The object from a scene's checked ``fields`` (its keys, ``stiffness``, ``friction`` and
        ``pose``); ``source`` locates the object in the file for errors."""
        return cls(**fields)

    def kernel_shape(self) -> tuple[int, list, np.ndarray | None]:
        """The shape as the compiled pad model reads it (:func:`tactile_bt.sim.kernels.pack_objects`):
        ``(shape code, parameters, signed-distance grid or None)``.

        This default samples :meth:`local_sdf` on a grid (:mod:`tactile_bt.sim.sdf_grid`, built
        once per object and shared by its moved copies) and gives the meshes' compiled path; a
        shape with a compiled form of its own overrides it."""
        grid = self.__dict__.get("_sampled_grid")
        if grid is None:
            bounds = self.local_bounds()
            grid = sdf_grid.sample_grid(self.local_sdf, bounds, sdf_grid.grid_cell(bounds))
            self._sampled_grid = grid
        return sdf_grid.kernel_form(grid)

    def surface_mesh(self):
        """The closed surface (a ``trimesh.Trimesh``, object frame, m) the accuracy metrics
        compare a scan with; None (this default) for objects a scan does not explore."""
        return None

    def view_surface(self, pv, extent: np.ndarray):
        """The surface ``tactile-bt view`` draws (a pyvista mesh in the object frame), or None.
        ``pv`` is the pyvista module, ``extent`` the ``(2, 3)`` world box shown. By default the
        :meth:`surface_mesh`."""
        mesh = self.surface_mesh()
        return None if mesh is None else pv.wrap(mesh)

    def centreline(self) -> tuple[np.ndarray, float] | None:
        """``(points, radius)``: the ``(N, 3)`` world centreline (m) and radius (m) of an object
        best drawn as a tube (a cable) in recordings; None (this default) for the others, drawn
        by their :meth:`surface_mesh`."""
        return None

    @property
    def identity_pose(self) -> bool:
        """True when the object frame is the world's (points are used as they are)."""
        return self._identity

    def local_bounds(self) -> np.ndarray:
        """``(2, 3)`` box ``[min, max]`` in the object frame that contains the object."""
        raise NotImplementedError

    # ------------------------------------------------------------------ world
    @property
    def area_stiffness(self) -> float:
        """Stiffness per area in Pa/m."""
        return self.stiffness / CONTACT_REFERENCE_AREA_M2

    def to_local(self, points: np.ndarray) -> np.ndarray:
        """World points ``(N, 3)`` in the object frame."""
        if self._identity:
            return points
        return (points - self._t) @ self._R

    def bounds(self) -> np.ndarray:
        """``(2, 3)`` axis-aligned box ``[min, max]`` (m, world) outside which there is no contact."""
        if self._world_bounds is None:
            b = np.asarray(self.local_bounds(), dtype=float)
            if self._identity:
                wb = b.copy()
            elif not np.all(np.isfinite(b)):
                # An unbounded shape (a table) keeps its bounds only if the pose keeps the axes.
                if np.allclose(self._R, np.eye(3)):
                    wb = b + self._t
                else:
                    wb = np.array([[-np.inf] * 3, [np.inf] * 3])
            else:
                centre, half = (b[0] + b[1]) / 2, (b[1] - b[0]) / 2
                c = self._R @ centre + self._t
                e = np.abs(self._R) @ half
                wb = np.array([c - e, c + e])
            wb.setflags(write=False)
            self._world_bounds = wb
        return self._world_bounds

    def sdf(self, points: np.ndarray) -> np.ndarray:
        """Signed distance (m) of each ``(N, 3)`` world point to the surface, negative inside."""
        return self.local_sdf(self.to_local(points))

    def penetration(self, points: np.ndarray) -> np.ndarray:
        """Depth (m, ≥ 0) of each ``(N, 3)`` world point inside the object."""
        return np.maximum(-self.sdf(points), 0.0)

    def depth(self, points: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """Indentation (m, ≥ 0) of pad points pressed along ``normal`` (world unit vector).

        How far each point has been pushed into the object along the pressing direction: the
        distance back along ``-normal`` to where that ray enters the object. It keeps growing as
        the pad presses on, past the middle of a thin object, so a soft pen or cable cannot be
        tunnelled through (the nearest-surface depth ``-sdf`` would shrink there). This default
        is ``-sdf``, right for thick objects; thin shapes override it with the ray depth.
        """
        return np.maximum(-self.sdf(points), 0.0)

    def with_pose(self, pose: np.ndarray) -> "SimObject":
        """A copy of the object at another world pose (shapes and grids are shared)."""
        other = copy.copy(self)
        other._set_pose(pose)
        return other

    def moved(self, translate=(0.0, 0.0, 0.0), rotate_deg=(0.0, 0.0, 0.0)) -> "SimObject":
        """A copy displaced in the world: first turned about its own origin by the extrinsic
        x-y-z angles ``rotate_deg`` (degrees, world axes), then shifted by ``translate`` (m)."""
        delta = Rotation.from_euler("xyz", np.asarray(rotate_deg, dtype=float), degrees=True).as_matrix()
        T = self.pose.copy()
        T[:3, :3] = delta @ T[:3, :3]
        T[:3, 3] = T[:3, 3] + np.asarray(translate, dtype=float)
        return self.with_pose(T)


@register_shape("table")
@dataclass(eq=False)
class Table(SimObject):
    """The half space below ``z = height`` (m) of its frame (the world's, by default)."""

    schema = {"height": COORD}
    example = {"height": 0.0}
    move_hint = "height"

    height: float = 0.0

    def local_bounds(self) -> np.ndarray:
        return np.array([[-np.inf, -np.inf, -np.inf], [np.inf, np.inf, self.height]])

    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        return points[:, 2] - self.height

    def kernel_shape(self) -> tuple[int, list, None]:
        return kernels.SHAPE_TABLE, [self.height], None

    def view_surface(self, pv, extent: np.ndarray):
        """A plane at the table top under the shown ``extent`` (world box)."""
        lo, hi = extent
        centre = self.to_local(np.array([[(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, 0.0]]))[0]
        centre[2] = self.height
        return pv.Plane(center=centre, i_size=hi[0] - lo[0], j_size=hi[1] - lo[1])


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


@register_shape("cable")
@dataclass(eq=False)
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

    All of these are in the cable's frame (``pose``, identity by default: the world's). The
    metrics' helpers (:meth:`distance_to_centreline`, :meth:`arc_position`) take world ``xy``
    and assume a pose that keeps the table horizontal (a shift and a turn about z).
    """

    schema = {
        "radius": Range(0.0, 0.05, lo_open=True, unit="m"),
        "table_height": COORD,
        "start": ListOf(2, COORD),
        "heading_deg": ANGLE_DEG,
        "path": LIST,
        "points": LIST,
    }
    example = {"radius": 0.003, "start": [-0.05, 0.0],
               "path": [{"straight": 0.05}, {"arc": {"radius": 0.05, "angle_deg": 90}}]}
    move_hint = "position, table_height"

    path: np.ndarray = None
    radius: float = 0.003
    table_height: float = 0.0
    grid_cell: float = 0.002

    @classmethod
    def from_scene(cls, fields: dict, source: ObjectSource) -> "Cable":
        """A cable from its ``points`` or its ``path`` pieces, checked
        (:func:`tactile_bt.sim.cable_path.centreline_from_scene`)."""
        points, rest = centreline_from_scene(fields, source)
        return cls(path=points, **rest)

    def __post_init__(self) -> None:
        super().__post_init__()
        self.path = np.ascontiguousarray(self.path, dtype=float)
        if self.path.ndim != 2 or self.path.shape[1] != 2 or len(self.path) < 2:
            raise ValueError("cable path must be an (N, 2) array with N >= 2")
        # Points outside the grid read its border, at least ``margin`` from the path: no contact,
        # as long as the margin exceeds the radius (a thick cable widens the grid).
        margin = max(0.01, self.radius + 0.005) + 2 * self.grid_cell
        self._grid, self._origin, self.length = _lateral_distance_grid(
            self.path.tobytes(), len(self.path), self.grid_cell, margin
        )
        lo = self.path.min(axis=0) - self.radius
        hi = self.path.max(axis=0) + self.radius
        self._local_bounds = np.array([[lo[0], lo[1], self.table_height],
                                       [hi[0], hi[1], self.table_height + 2 * self.radius]])

    def local_bounds(self) -> np.ndarray:
        return self._local_bounds

    def kernel_shape(self) -> tuple[int, list, np.ndarray]:
        return (kernels.SHAPE_CABLE, [self.radius, self.table_height, self._origin[0], self._origin[1],
                                      1.0 / self.grid_cell], self._grid)

    def lateral_distance(self, xy: np.ndarray) -> np.ndarray:
        """Signed horizontal distance (m) of ``(N, 2)`` points from the centreline (bilinear on a
        precomputed grid; exact for straight pieces, O(cell²·curvature) on arcs). Points off the
        grid read its border, which lies farther than any contact reaches."""
        coords = ((xy - self._origin) * (1.0 / self.grid_cell)).T
        return ndimage.map_coordinates(self._grid, coords, order=1, mode="nearest", prefilter=False)

    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        lateral = self.lateral_distance(points[:, :2])
        dz = points[:, 2] - (self.table_height + self.radius)
        return np.sqrt(lateral * lateral + dz * dz) - self.radius

    def depth(self, points: np.ndarray, normal: np.ndarray) -> np.ndarray:
        """Ray depth of a pad pressing from above (``normal`` pointing down): below the cable's
        top at the point's lateral offset, along the normal; −sdf for other directions."""
        n = self.pose[:3, :3].T @ normal
        if n[2] > -0.5:  # not pressing from above: nearest-surface depth
            return super().depth(points, normal)
        local = self.to_local(points)
        lateral = self.lateral_distance(local[:, :2])
        half = np.sqrt(np.maximum(self.radius * self.radius - lateral * lateral, 0.0))
        top = self.table_height + self.radius + half
        d = (top - local[:, 2]) / -n[2]
        return np.where(half > 0.0, np.maximum(d, 0.0), 0.0)

    def _centreline_local(self) -> np.ndarray:
        return np.column_stack((self.path, np.full(len(self.path), self.table_height + self.radius)))

    def centreline_world(self) -> np.ndarray:
        """``(N, 3)`` world points of the centreline (for views and metrics)."""
        local = self._centreline_local()
        return local if self._identity else local @ self._R.T + self._t

    def centreline(self) -> tuple[np.ndarray, float]:
        return self.centreline_world(), self.radius

    def view_surface(self, pv, extent: np.ndarray):
        """A tube around the centreline (every other point of it)."""
        pts = self._centreline_local()
        return pv.lines_from_points(pts[::2] if len(pts) > 4 else pts).tube(radius=self.radius, n_sides=16)

    def _local_xy(self, xy: np.ndarray) -> np.ndarray:
        """World ``(N, 2)`` table points in the cable's frame (taken at the centreline's height)."""
        xy = np.asarray(xy, dtype=float)
        if self._identity:
            return xy
        z = (self._R @ [0.0, 0.0, self.table_height + self.radius] + self._t)[2]
        return self.to_local(np.column_stack((xy, np.full(len(xy), z))))[:, :2]

    def distance_to_centreline(self, xy: np.ndarray) -> np.ndarray:
        """Horizontal distance (m) of ``(N, 2)`` points to the true centreline (exact, for metrics)."""
        xy = self._local_xy(xy)
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
        xy = self._local_xy(xy)
        s = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(self.path, axis=0).T))))
        _, idx = cKDTree(self.path).query(xy)
        return s[idx]

