"""Primitive objects with exact signed distances: box, sphere, cylinder (a pen).

Each shape is centred on its frame's origin (``pose`` places it in the world, see
:class:`tactile_bt.sim.objects.SimObject`). The signed distances are exact Euclidean
distances, hence 1-Lipschitz, negative inside. Each has a compiled form of its own in
:mod:`tactile_bt.sim.kernels` (``kernel_shape``) and a ray depth (``depth``).

Layer: sim.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tactile_bt.sim import kernels
from tactile_bt.sim.objects import SimObject
from tactile_bt.sim.registry import register_shape
from tactile_bt.sim.schema import LENGTH, ListOf

__all__ = ["Box", "Sphere", "Cylinder", "positive"]


def _ray_depth(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Depth from the interval [lo, hi] of ray parameters (distance back along −normal) where the
    ray lies inside a convex shape: ``hi`` when the ray meets the shape behind the point."""
    return np.where((hi > 0.0) & (lo <= hi), hi, 0.0)


def _slab(p: np.ndarray, n: np.ndarray, half) -> tuple[np.ndarray, np.ndarray]:
    """Parameters s of ``p − s n`` with ``|coordinate| ≤ half`` along one axis."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a = (p - half) / n
        b = (p + half) / n
    if n == 0.0:
        inside = np.abs(p) <= half
        return np.where(inside, -np.inf, np.inf), np.where(inside, np.inf, -np.inf)
    return np.minimum(a, b), np.maximum(a, b)


def positive(name: str, value: float) -> float:
    """``value`` as a float, or a ValueError naming ``name`` when it is not a positive number."""
    value = float(value)
    if not np.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a positive number, got {value!r}")
    return value


@register_shape("box")
@dataclass(eq=False)
class Box(SimObject):
    """A rectangular box of edge lengths ``size`` = [x, y, z] (m), centred on its origin.

    Sharp edges and corners; a flat face pressed on the pad gives a uniform image, an edge a
    line.
    """

    schema = {"size": ListOf(3, LENGTH)}
    required = ("size",)
    example = {"size": [0.16, 0.12, 0.06]}

    size: tuple = (0.1, 0.1, 0.1)

    def __post_init__(self) -> None:
        self.size = tuple(positive(f"box size[{i}]", v) for i, v in enumerate(self.size))
        if len(self.size) != 3:
            raise ValueError("box size must be [x, y, z]")
        self._half = 0.5 * np.array(self.size)
        super().__post_init__()

    def local_bounds(self) -> np.ndarray:
        return np.array([-self._half, self._half])

    def kernel_shape(self) -> tuple[int, list, None]:
        return kernels.SHAPE_BOX, list(self._half), None

    def surface_mesh(self):
        import trimesh

        return trimesh.creation.box(extents=self.size)

    def view_surface(self, pv, extent: np.ndarray):
        hx, hy, hz = self._half
        return pv.Box(bounds=(-hx, hx, -hy, hy, -hz, hz))

    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        q = np.abs(points) - self._half
        outside = np.maximum(q, 0.0)
        return np.sqrt(np.einsum("ij,ij->i", outside, outside)) + np.minimum(q.max(axis=1), 0.0)

    def depth(self, points: np.ndarray, normal: np.ndarray) -> np.ndarray:
        p, n = self.to_local(points), self.pose[:3, :3].T @ normal
        lo, hi = _slab(p[:, 0], n[0], self._half[0])
        for i in (1, 2):
            a, b = _slab(p[:, i], n[i], self._half[i])
            lo, hi = np.maximum(lo, a), np.minimum(hi, b)
        return _ray_depth(lo, hi)


@register_shape("sphere")
@dataclass(eq=False)
class Sphere(SimObject):
    """A ball of ``radius`` (m) centred on its origin."""

    schema = {"radius": LENGTH}
    required = ("radius",)
    example = {"radius": 0.05}

    radius: float = 0.05

    def __post_init__(self) -> None:
        self.radius = positive("sphere radius", self.radius)
        super().__post_init__()

    def local_bounds(self) -> np.ndarray:
        r = self.radius
        return np.array([[-r, -r, -r], [r, r, r]])

    def kernel_shape(self) -> tuple[int, list, None]:
        return kernels.SHAPE_SPHERE, [self.radius], None

    def surface_mesh(self):
        """An icosphere of 5 subdivisions (20 480 triangles)."""
        import trimesh

        return trimesh.creation.icosphere(subdivisions=5, radius=self.radius)

    def view_surface(self, pv, extent: np.ndarray):
        return pv.Sphere(radius=self.radius, theta_resolution=48, phi_resolution=48)

    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        return np.sqrt(np.einsum("ij,ij->i", points, points)) - self.radius

    def depth(self, points: np.ndarray, normal: np.ndarray) -> np.ndarray:
        p, n = self.to_local(points), self.pose[:3, :3].T @ normal
        b = p @ n
        disc = b * b - np.einsum("ij,ij->i", p, p) + self.radius**2
        root = np.sqrt(np.maximum(disc, 0.0))
        return np.where(disc > 0.0, _ray_depth(b - root, b + root), 0.0)


@register_shape("cylinder")
@dataclass(eq=False)
class Cylinder(SimObject):
    """A solid cylinder of ``radius`` and ``length`` (m) with flat ends, its axis along the
    object's x, centred on its origin. A pen lying on a table: ``rpy_deg [0, 0, yaw]`` and the
    centre ``radius`` above the table top."""

    schema = {"radius": LENGTH, "length": LENGTH}
    required = ("radius", "length")
    example = {"radius": 0.005, "length": 0.14}

    radius: float = 0.005
    length: float = 0.14

    def __post_init__(self) -> None:
        self.radius = positive("cylinder radius", self.radius)
        self.length = positive("cylinder length", self.length)
        super().__post_init__()

    def local_bounds(self) -> np.ndarray:
        r, h = self.radius, self.length / 2
        return np.array([[-h, -r, -r], [h, r, r]])

    def kernel_shape(self) -> tuple[int, list, None]:
        return kernels.SHAPE_CYLINDER, [self.radius, self.length / 2], None

    def surface_mesh(self):
        """256 sections, the axis along x."""
        import trimesh

        mesh = trimesh.creation.cylinder(radius=self.radius, height=self.length, sections=256)
        mesh.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))  # axis z → x
        return mesh

    def view_surface(self, pv, extent: np.ndarray):
        return pv.Cylinder(radius=self.radius, height=self.length, direction=(1, 0, 0), resolution=48)

    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        radial = np.hypot(points[:, 1], points[:, 2]) - self.radius
        axial = np.abs(points[:, 0]) - self.length / 2
        outside = np.hypot(np.maximum(radial, 0.0), np.maximum(axial, 0.0))
        return outside + np.minimum(np.maximum(radial, axial), 0.0)

    def depth(self, points: np.ndarray, normal: np.ndarray) -> np.ndarray:
        p, n = self.to_local(points), self.pose[:3, :3].T @ normal
        lo, hi = _slab(p[:, 0], n[0], self.length / 2)
        a = n[1] * n[1] + n[2] * n[2]
        if a > 1e-12:  # the ray crosses the round surface: |(p − s n)_yz| ≤ r
            b = (p[:, 1] * n[1] + p[:, 2] * n[2]) / a
            disc = b * b - (p[:, 1] ** 2 + p[:, 2] ** 2 - self.radius**2) / a
            root = np.sqrt(np.maximum(disc, 0.0))
            lo = np.where(disc > 0.0, np.maximum(lo, b - root), np.inf)
            hi = np.where(disc > 0.0, np.minimum(hi, b + root), -np.inf)
        else:  # along the axis
            inside = p[:, 1] ** 2 + p[:, 2] ** 2 <= self.radius**2
            lo, hi = np.where(inside, lo, np.inf), np.where(inside, hi, -np.inf)
        return _ray_depth(lo, hi)
