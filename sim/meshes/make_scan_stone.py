"""Regenerate scan_stone.ply: the lumpy stone of sim/scan_stone.yaml.

A flat, asymmetric stone about 150 x 105 x 50 mm lying on its flat base: an icosphere
(5 subdivisions, 20 480 triangles, edges of about 3 mm) whose radius carries a dozen smooth
bumps and hollows (Gaussian, 8-20 % of the radius, drawn with a fixed seed), stretched to the
stone's size, its top leaning towards +x, and its lower half flattened to z = 0. Coordinates
in metres, the base centred on the origin. Run:

    python sim/meshes/make_scan_stone.py
"""

from pathlib import Path

import numpy as np
import trimesh

SEMI_AXES = (0.066, 0.044, 0.040)  # x, y, z (m) before the bumps
SEED = 7
BUMPS = 16


def make() -> trimesh.Trimesh:
    sphere = trimesh.creation.icosphere(subdivisions=5)
    v = sphere.vertices  # unit vectors
    rng = np.random.default_rng(SEED)
    centres = rng.normal(size=(BUMPS, 3))
    centres[:, 2] = np.abs(centres[:, 2]) + 0.3  # on the upper half, which is the stone's top
    centres /= np.linalg.norm(centres, axis=1, keepdims=True)
    heights = rng.uniform(0.05, 0.12, BUMPS) * rng.choice([-1.0, 1.0], BUMPS, p=[0.4, 0.6])
    widths = rng.uniform(0.2, 0.35, BUMPS)
    d2 = ((v[:, None, :] - centres[None, :, :]) ** 2).sum(axis=2)
    radius = 1.0 + (heights * np.exp(-d2 / (2 * widths**2))).sum(axis=1)
    p = v * radius[:, None]
    x, y, z = p.T
    X = SEMI_AXES[0] * x
    Y = SEMI_AXES[1] * y * (1.0 - 0.12 * x)
    Z = SEMI_AXES[2] * z * (1.0 + 0.15 * x)
    Z = np.maximum(Z, 0.0)
    return trimesh.Trimesh(np.column_stack((X, Y, Z)), sphere.faces, process=False)


if __name__ == "__main__":
    mesh = make()
    assert mesh.is_watertight, "the stone must be closed"
    out = Path(__file__).with_name("scan_stone.ply")
    mesh.export(out)
    print(f"{out}: {len(mesh.faces)} triangles, bounds {mesh.bounds.tolist()}")
