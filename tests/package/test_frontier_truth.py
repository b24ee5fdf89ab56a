"""docs/frontier_truth.py reads the object's true slope from the scene's own shape and tells
samples lying on a plane from scattered ones."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import numpy.testing as npt

from tactile_bt.sim.scene import load_scene

REPO = Path(__file__).resolve().parents[2]


def _module():
    sys.path.insert(0, str(REPO / "docs"))
    spec = importlib.util.spec_from_file_location("frontier_truth", REPO / "docs" / "frontier_truth.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


TRUTH = _module()


def test_the_true_tilt_on_the_shipped_torus_follows_its_tube():
    scene = load_scene(REPO / "sim" / "scan_torus.yaml")
    R, r, zc = 0.06, 0.025, 0.025  # the scene's ring: major, minor radius, centre height (m)
    angles = np.radians([0.0, 30.0, 60.0])  # from the top of the tube towards the hole
    points = np.column_stack((R - r * np.sin(angles), np.zeros(3), zc + r * np.cos(angles)))
    npt.assert_allclose(TRUTH.true_tilt(scene.objects, points), [0.0, 30.0, 60.0], atol=0.5)


def test_samples_on_a_plane_lie_flat_and_a_scattered_blob_does_not():
    rng = np.random.default_rng(3)
    plane = np.column_stack((rng.uniform(-0.005, 0.005, (400, 2)), rng.normal(0.0, 1e-4, 400)))
    blob = rng.normal(0.0, 0.002, (400, 3))
    centre = np.zeros((1, 3))
    assert TRUTH.flatness(plane, centre)[0] < 0.1
    assert TRUTH.flatness(blob, centre)[0] > 0.5
    assert np.isnan(TRUTH.flatness(plane[:5], centre)[0])
