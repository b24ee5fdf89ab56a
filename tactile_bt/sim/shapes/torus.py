"""A torus: a ring with an inward-curving (saddle) surface on its inner side.

The torus lies in its frame's x-y plane, its axis along z, centred on the origin. Lying flat on
a table of height 0 it has ``position: [x, y, minor_radius]``. Its outer side curves like a
ball's (both principal curvatures towards the inside), its inner side, facing the hole, is a
saddle: the surface a pad meets there curves away from it in one direction and towards it in
the other, the case exploration of concave surfaces needs.

The pad model reads it through a signed-distance grid sampled from the exact distance
(:meth:`tactile_bt.sim.objects.SimObject.kernel_shape`, 1 mm cells: off by at most a few
micrometres near the surface); its depth is the nearest-surface depth ``-sdf``, right for a tube
thicker than the pad presses in.

Layer: sim.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from tactile_bt.sim.objects import SimObject
from tactile_bt.sim.registry import ShapeValueError, register_shape
from tactile_bt.sim.schema import LENGTH
from tactile_bt.sim.shapes.primitives import positive

__all__ = ["Torus", "CHORD_TOLERANCE_M"]

#: Largest distance (m) of the surface mesh's facets from the true surface (accuracy metrics).
CHORD_TOLERANCE_M = 1.0e-5


def _sections(radius: float) -> int:
    """Polygon sections around a circle of ``radius`` (m) whose chords stay within
    :data:`CHORD_TOLERANCE_M` of it (32 to 512)."""
    half_angle = math.acos(max(1.0 - CHORD_TOLERANCE_M / radius, -1.0))
    return int(min(max(math.ceil(math.pi / half_angle), 32), 512))


@register_shape("torus")
@dataclass(eq=False)
class Torus(SimObject):
    """A torus of ``major_radius`` (m, from its axis to the centre circle of the tube) and
    ``minor_radius`` (m, the tube's), its axis along the object's z, centred on the origin.

    The hole is kept open: ``minor_radius < major_radius``.
    """

    schema = {"major_radius": LENGTH, "minor_radius": LENGTH}
    required = ("major_radius", "minor_radius")
    example = {"major_radius": 0.06, "minor_radius": 0.02}

    major_radius: float = 0.06
    minor_radius: float = 0.02

    def __post_init__(self) -> None:
        self.major_radius = positive("torus major_radius", self.major_radius)
        self.minor_radius = positive("torus minor_radius", self.minor_radius)
        if self.minor_radius >= self.major_radius:
            raise ShapeValueError("minor_radius", f"the tube's radius ({self.minor_radius:g} m) must be smaller "
                                  f"than major_radius ({self.major_radius:g} m), or the hole closes")
        super().__post_init__()

    def local_bounds(self) -> np.ndarray:
        a, r = self.major_radius + self.minor_radius, self.minor_radius
        return np.array([[-a, -a, -r], [a, a, r]])

    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        radial = np.hypot(points[:, 0], points[:, 1]) - self.major_radius
        return np.hypot(radial, points[:, 2]) - self.minor_radius

    def surface_mesh(self):
        """Facets within :data:`CHORD_TOLERANCE_M` of the surface (about 40 000 for a 60 mm ring
        of a 20 mm tube)."""
        import trimesh

        return trimesh.creation.torus(self.major_radius, self.minor_radius,
                                      major_sections=_sections(self.major_radius + self.minor_radius),
                                      minor_sections=_sections(self.minor_radius))
