"""A block with a concave groove along its top: a surface that curves towards the pad.

The block is a box of edge lengths ``size`` = [x, y, z] centred on its frame's origin (lying on a
table of height 0 it has ``position: [x, y, size_z / 2]``). Along its y axis, a channel of
circular cross-section is cut into its top face: ``groove_width`` wide at the top and
``groove_depth`` deep at its middle (the arc's radius follows from the two). A flat pad wider
than the channel's flat-enough part bridges it: pressed down, it touches the two walls rather
than the bottom, the case of exploration on concave surfaces.

The signed distance is ``max(box, -channel)``: exact inside the block away from the groove's
rims, zero exactly on the surface, 1-Lipschitz, a lower bound of the distance near the rims
(within a millimetre). The pad model reads it through a grid
(:meth:`tactile_bt.sim.objects.SimObject.kernel_shape`).

Layer: sim.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_bt.sim.objects import SimObject
from tactile_bt.sim.registry import ShapeValueError, register_shape
from tactile_bt.sim.schema import LENGTH, ListOf
from tactile_bt.sim.shapes.primitives import positive

__all__ = ["GroovedBlock", "CHORD_TOLERANCE_M"]

#: Largest distance (m) of the surface mesh's facets from the groove's arc (accuracy metrics).
CHORD_TOLERANCE_M = 1.0e-5


@register_shape("grooved_block")
@dataclass(eq=False)
class GroovedBlock(SimObject):
    """A box of ``size`` = [x, y, z] (m) with a channel of circular cross-section along its y
    axis cut into its top: ``groove_width`` (m) across at the top, ``groove_depth`` (m) deep.

    The channel fits in the top face: ``groove_width < size[0]``, ``groove_depth < size[2]``.
    """

    schema = {"size": ListOf(3, LENGTH), "groove_width": LENGTH, "groove_depth": LENGTH}
    required = ("size", "groove_width", "groove_depth")
    example = {"size": [0.16, 0.14, 0.05], "groove_width": 0.108, "groove_depth": 0.01}

    size: tuple = (0.16, 0.14, 0.05)
    groove_width: float = 0.108
    groove_depth: float = 0.01

    def __post_init__(self) -> None:
        self.size = tuple(positive(f"grooved_block size[{i}]", v) for i, v in enumerate(self.size))
        self.groove_width = positive("groove_width", self.groove_width)
        self.groove_depth = positive("groove_depth", self.groove_depth)
        if self.groove_width >= self.size[0]:
            raise ShapeValueError("groove_width", f"the groove ({self.groove_width:g} m) must be narrower than the "
                                  f"block (size[0] = {self.size[0]:g} m)")
        if self.groove_depth >= self.size[2] or self.groove_depth > 0.5 * self.groove_width:
            raise ShapeValueError("groove_depth", f"the groove's depth ({self.groove_depth:g} m) must be less than "
                                  f"the block's height and at most half its width")
        self._half = 0.5 * np.array(self.size)
        half_width, depth = 0.5 * self.groove_width, self.groove_depth
        #: the channel's radius (m) and the height of its axis above the block's centre (m)
        self.groove_radius = (half_width ** 2 + depth ** 2) / (2.0 * depth)
        self._axis_z = self._half[2] - depth + self.groove_radius
        super().__post_init__()

    def local_bounds(self) -> np.ndarray:
        return np.array([-self._half, self._half])

    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        q = np.abs(points) - self._half
        outside = np.maximum(q, 0.0)
        box = np.sqrt(np.einsum("ij,ij->i", outside, outside)) + np.minimum(q.max(axis=1), 0.0)
        channel = np.hypot(points[:, 0], points[:, 2] - self._axis_z) - self.groove_radius
        return np.maximum(box, -channel)

    def top_profile(self) -> tuple[np.ndarray, np.ndarray]:
        """x and z (m) of the top's cross-section from ``-size_x/2`` to ``+size_x/2``: flat,
        the arc of the groove (chords within :data:`CHORD_TOLERANCE_M`), flat."""
        half_angle = math.asin(0.5 * self.groove_width / self.groove_radius)
        step = 2.0 * math.acos(1.0 - CHORD_TOLERANCE_M / self.groove_radius)
        angles = np.linspace(-half_angle, half_angle, max(int(math.ceil(2 * half_angle / step)), 8) + 1)
        x = np.concatenate(([-self._half[0]], self.groove_radius * np.sin(angles), [self._half[0]]))
        z = np.concatenate(([self._half[2]], self._axis_z - self.groove_radius * np.cos(angles), [self._half[2]]))
        z[1], z[-2] = self._half[2], self._half[2]     # the rims exactly on the top face
        return x, z

    def surface_mesh(self):
        """A closed prism along y over the top profile (strips of quads, each two triangles)."""
        import trimesh

        x, z = self.top_profile()
        n, hy, bottom = len(x), self._half[1], -self._half[2]
        # vertices: top at -y, top at +y, bottom at -y, bottom at +y (n each)
        vertices = np.concatenate([np.column_stack((x, np.full(n, y), zz)) for zz, y in
                                   ((z, -hy), (z, hy), (np.full(n, bottom), -hy), (np.full(n, bottom), hy))])
        t0, t1, b0, b1 = 0, n, 2 * n, 3 * n
        faces = []

        def quad(a, b, c, d):  # counter-clockwise seen from outside
            faces.extend(([a, b, c], [a, c, d]))

        for i in range(n - 1):
            quad(t0 + i, t1 + i, t1 + i + 1, t0 + i + 1)          # top
            quad(b0 + i, b0 + i + 1, b1 + i + 1, b1 + i)          # bottom
            quad(b0 + i, t0 + i, t0 + i + 1, b0 + i + 1)          # end at -y
            quad(b1 + i, b1 + i + 1, t1 + i + 1, t1 + i)          # end at +y
        quad(b0, b1, t1, t0)                                       # side at -x
        quad(b0 + n - 1, t0 + n - 1, t1 + n - 1, b1 + n - 1)       # side at +x
        mesh = trimesh.Trimesh(vertices, np.array(faces), process=True)
        if mesh.volume < 0:
            mesh.invert()
        return mesh
