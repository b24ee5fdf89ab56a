"""A capsule: a cylinder with hemispherical ends, such as a pill or a rounded log lying on a table.

The capsule's axis lies along its frame's x, centred on the origin: a segment of ``length``
between the centres of its two end spheres of ``radius``. Lying on a table of height 0 it has
``position: [x, y, radius]``. The signed distance is exact (the distance from the axis segment
less the radius); the pad model reads it through the signed-distance grid of
:meth:`tactile_bt.sim.objects.SimObject.kernel_shape`.

Layer: sim.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tactile_bt.sim.objects import SimObject
from tactile_bt.sim.registry import register_shape
from tactile_bt.sim.schema import LENGTH
from tactile_bt.sim.shapes.primitives import positive

__all__ = ["Capsule"]


@register_shape("capsule")
@dataclass(eq=False)
class Capsule(SimObject):
    """A capsule of ``radius`` (m) whose straight part is ``length`` (m) long along the
    object's x; ``length + 2 radius`` long in all."""

    schema = {"radius": LENGTH, "length": LENGTH}
    required = ("radius", "length")
    example = {"radius": 0.03, "length": 0.1}

    radius: float = 0.03
    length: float = 0.1

    def __post_init__(self) -> None:
        self.radius = positive("capsule radius", self.radius)
        self.length = positive("capsule length", self.length)
        super().__post_init__()

    def local_bounds(self) -> np.ndarray:
        r, h = self.radius, self.length / 2
        return np.array([[-h - r, -r, -r], [h + r, r, r]])

    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        on_axis = np.clip(points[:, 0], -self.length / 2, self.length / 2)
        return np.sqrt((points[:, 0] - on_axis) ** 2 + points[:, 1] ** 2 + points[:, 2] ** 2) - self.radius

    def surface_mesh(self):
        """The capsule with 128 sections, its axis along x."""
        import trimesh

        mesh = trimesh.creation.capsule(height=self.length, radius=self.radius, count=[128, 64])
        mesh.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))  # axis z → x
        return mesh
