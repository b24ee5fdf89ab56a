"""docs/frontier_truth.py reads the object's true slope and how far a sample lies off it from the
scene's own shape, and tells samples lying on a plane from scattered ones."""

from pathlib import Path

import numpy as np
import numpy.testing as npt

from tactile_bt.sim.scene import load_scene
from docs_scripts import load_docs_script

REPO = Path(__file__).resolve().parents[2]


TRUTH = load_docs_script("frontier_truth")


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


def test_what_the_contacts_left_is_measured_on_the_surface_and_in_the_table_plane():
    # contacts over the torus's upper side but its inner quarter (tilted 30-60 deg towards the hole):
    # that band is left, steeper on the surface than in the table plane
    scene = load_scene(REPO / "sim" / "scan_torus.yaml")
    R, r, zc = 0.06, 0.025, 0.025
    rng = np.random.default_rng(7)
    around, down = rng.uniform(0.0, 2 * np.pi, 200000), rng.uniform(-np.pi / 3, np.pi / 6, 200000)
    radius = R - r * np.sin(down)  # down > 0: towards the hole
    points = np.column_stack((radius * np.cos(around), radius * np.sin(around), zc + r * np.cos(down)))
    estimate = {"untouched_near_table_m2": 0.0, "untouched_in_valleys_m2": 0.001, "untouched_beyond_reach_m2": 0.0,
                "untouched_at_hole_rims_m2": 0.0, "estimated_coverage": 0.9}
    line = TRUTH.left_untouched(scene, estimate, points)
    assert "the estimate counts 10.0 cm² in the table plane (10.0 in valleys; estimated coverage 0.900)" in line
    first = np.pi / 6 + 0.002 / r  # the contacts cover 2 mm of the band; the region ends at 60 deg
    band_surface = 2 * np.pi * r * (R * (np.pi / 3 - first) + r * (np.cos(np.pi / 3) - np.cos(first)))
    band_plane = np.pi * ((R - r * np.sin(first)) ** 2 - (R - r * np.sin(np.pi / 3)) ** 2)
    surface = float(line.split(" cm² on its surface")[0].split(" and ")[-1])
    plane = float(line.split(" cm² of the region in the table plane")[0].split("the contacts left ")[-1])
    # within the true mesh's facets and the fuzzy edge of what the contacts cover
    npt.assert_allclose(surface, band_surface * 1e4, rtol=0.1)
    npt.assert_allclose(plane, band_plane * 1e4, rtol=0.1)
    npt.assert_allclose(surface / plane, band_surface / band_plane, rtol=0.03)  # a steep band weighs more on the surface
