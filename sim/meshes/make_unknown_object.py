"""Regenerate unknown_object.ply: the "unknown object" of sim/object.yaml.

A smooth, asymmetric pebble about 121 x 81 x 33 mm with a flat base (it lies on the table) and
a shallow dent in its top, so that a surface scan sees changing curvature. An icosphere
(5 subdivisions, 20 480 triangles) is stretched and bent, and its lower half flattened to z = 0.
Coordinates in metres, the base centred on the origin. Run:

    python sim/meshes/make_unknown_object.py
"""

from pathlib import Path

import numpy as np
import trimesh


def make() -> trimesh.Trimesh:
    sphere = trimesh.creation.icosphere(subdivisions=5)
    x, y, z = sphere.vertices.T
    X = 0.060 * x * (1 + 0.12 * y)
    Y = 0.040 * y * (1 - 0.15 * x)
    Z = 0.035 * z * (1 + 0.25 * x) * (1 - 0.10 * np.exp(-((x - 0.2) ** 2 + y**2) / 0.08))
    Z = np.maximum(Z, 0.0)
    return trimesh.Trimesh(np.column_stack((X, Y, Z)), sphere.faces, process=False)


if __name__ == "__main__":
    mesh = make()
    assert mesh.is_watertight
    out = Path(__file__).with_name("unknown_object.ply")
    mesh.export(out)
    print(f"{out}: {len(mesh.faces)} triangles, bounds {mesh.bounds.tolist()}")
