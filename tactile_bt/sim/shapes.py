"""Primitive objects with exact signed distances: box, sphere, cylinder (a pen).

Each shape is centred on its frame's origin (``pose`` places it in the world, see
:class:`tactile_bt.sim.objects.SimObject`). The signed distances are exact Euclidean
distances, hence 1-Lipschitz, negative inside.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tactile_bt.sim.objects import SimObject

__all__ = ["Box", "Sphere", "Cylinder"]


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not np.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a positive number, got {value!r}")
    return value


@dataclass(eq=False)
class Box(SimObject):
    """A rectangular box of edge lengths ``size`` = [x, y, z] (m), centred on its origin.

    Sharp edges and corners; a flat face pressed on the pad gives a uniform image, an edge a
    line.
    """

    size: tuple = (0.1, 0.1, 0.1)

    def __post_init__(self) -> None:
        self.size = tuple(_positive(f"box size[{i}]", v) for i, v in enumerate(self.size))
        if len(self.size) != 3:
            raise ValueError("box size must be [x, y, z]")
        self._half = 0.5 * np.array(self.size)
        super().__post_init__()

    def local_bounds(self) -> np.ndarray:
        return np.array([-self._half, self._half])

    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        q = np.abs(points) - self._half
        outside = np.maximum(q, 0.0)
        return np.sqrt(np.einsum("ij,ij->i", outside, outside)) + np.minimum(q.max(axis=1), 0.0)


@dataclass(eq=False)
class Sphere(SimObject):
    """A ball of ``radius`` (m) centred on its origin."""

    radius: float = 0.05

    def __post_init__(self) -> None:
        self.radius = _positive("sphere radius", self.radius)
        super().__post_init__()

    def local_bounds(self) -> np.ndarray:
        r = self.radius
        return np.array([[-r, -r, -r], [r, r, r]])

    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        return np.sqrt(np.einsum("ij,ij->i", points, points)) - self.radius


@dataclass(eq=False)
class Cylinder(SimObject):
    """A solid cylinder of ``radius`` and ``length`` (m) with flat ends, its axis along the
    object's x, centred on its origin. A pen lying on a table: ``rpy_deg [0, 0, yaw]`` and the
    centre ``radius`` above the table top."""

    radius: float = 0.005
    length: float = 0.14

    def __post_init__(self) -> None:
        self.radius = _positive("cylinder radius", self.radius)
        self.length = _positive("cylinder length", self.length)
        super().__post_init__()

    def local_bounds(self) -> np.ndarray:
        r, h = self.radius, self.length / 2
        return np.array([[-h, -r, -r], [h, r, r]])

    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        radial = np.hypot(points[:, 1], points[:, 2]) - self.radius
        axial = np.abs(points[:, 0]) - self.length / 2
        outside = np.hypot(np.maximum(radial, 0.0), np.maximum(axial, 0.0))
        return outside + np.minimum(np.maximum(radial, axial), 0.0)
