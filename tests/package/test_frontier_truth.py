"""docs/frontier_truth.py reads the object's true slope and how far a sample lies off it from the
scene's own shape, and tells samples lying on a plane from scattered ones."""

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


def test_a_sample_in_the_air_beside_the_torus_is_as_far_outside_as_it_lies():
    scene = load_scene(REPO / "sim" / "scan_torus.yaml")
    R, r, zc = 0.06, 0.025, 0.025
    # on the tube's top, 3 mm above it, 2 mm into the hole from its innermost point, 1 mm inside
    points = np.array([[R, 0.0, zc + r], [R, 0.0, zc + r + 0.003], [R - r - 0.002, 0.0, zc], [0.0, R, zc + r - 0.001]])
    npt.assert_allclose(TRUTH.off_object(scene.objects, points), [0.0, 0.003, 0.002, -0.001], atol=1e-6)


def test_samples_on_a_plane_lie_flat_and_a_scattered_blob_does_not():
    rng = np.random.default_rng(3)
    plane = np.column_stack((rng.uniform(-0.005, 0.005, (400, 2)), rng.normal(0.0, 1e-4, 400)))
    blob = rng.normal(0.0, 0.002, (400, 3))
    centre = np.zeros((1, 3))
    assert TRUTH.flatness(plane, centre)[0] < 0.1
    assert TRUTH.flatness(blob, centre)[0] > 0.5
    assert np.isnan(TRUTH.flatness(plane[:5], centre)[0])
