"""Regenerate scan_ellipsoid.ply: the doubly curved object of sim/scan_ellipsoid.yaml.

An ellipsoid with semi-axes 80 x 55 x 40 mm (x, y, z), a rugby ball lying on its side: its
radii of curvature run from 160 mm and 76 mm at the top down to 20 mm at the ends of its long
axis. An icosphere (5 subdivisions, 20 480 triangles, edges of about 3 mm) is scaled.
Coordinates in metres, centred on the origin. Run:

    python sim/meshes/make_scan_ellipsoid.py
"""

from pathlib import Path

import numpy as np
import trimesh

SEMI_AXES = (0.080, 0.055, 0.040)


def make() -> trimesh.Trimesh:
    sphere = trimesh.creation.icosphere(subdivisions=5)
    return trimesh.Trimesh(sphere.vertices * np.array(SEMI_AXES), sphere.faces, process=False)


if __name__ == "__main__":
    mesh = make()
    assert mesh.is_watertight, "the ellipsoid must be closed"
    out = Path(__file__).with_name("scan_ellipsoid.ply")
    mesh.export(out)
    print(f"{out}: {len(mesh.faces)} triangles, bounds {mesh.bounds.tolist()}")
