"""Surface reconstruction from contact clouds sampled from known shapes: every method, the
cleaning, thinning, and the bench function."""

import numpy as np
import pytest
import trimesh

from tactile_bt.experiments.bench import bench_reconstruction
from tactile_bt.contacts.reconstruct import (METHODS, best_fit_plane, clean_mesh, cloud_spacing,
                                    reconstruct, thin_cloud, write_surface)
from tactile_bt.mission.accuracy import reconstruction_metrics


def plane_cloud(spacing=0.002, size=0.1, z=0.05, tilt_deg=0.0):
    """A square grid of points with upward normals, optionally tilted about x."""
    g = np.arange(-size / 2, size / 2 + 1e-9, spacing)
    x, y = np.meshgrid(g, g)
    points = np.column_stack((x.ravel(), y.ravel(), np.zeros(x.size)))
    c, s = np.cos(np.radians(tilt_deg)), np.sin(np.radians(tilt_deg))
    R = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    return points @ R.T + (0, 0, z), np.tile(R[:, 2], (len(points), 1))


def sphere_cloud(n=6000, radius=0.05, seed=0, upper_only=False):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    if upper_only:
        v[:, 2] = np.abs(v[:, 2])
    return radius * v, v


def test_thin_cloud_keeps_the_first_point_of_each_voxel():
    points = np.array([[0.0001, 0, 0], [0.0009, 0, 0], [0.0011, 0, 0], [0.0002, 0.0002, 0.0002], [-0.0001, 0, 0]])
    assert thin_cloud(points, 0.001).tolist() == [0, 2, 4]
    assert thin_cloud(points, 0.0).tolist() == [0, 1, 2, 3, 4]
    dense, _ = plane_cloud(spacing=0.0005, size=0.01)
    kept = thin_cloud(dense, 0.002)
    assert len(kept) == 6 * 6  # 10 mm (+ one edge) in 2 mm voxels


def test_cloud_spacing_and_best_fit_plane():
    points, normals = plane_cloud(spacing=0.002, tilt_deg=30)
    assert cloud_spacing(points) == pytest.approx(0.002)
    centre, frame = best_fit_plane(points, normals)
    np.testing.assert_allclose(frame[2], normals[0], atol=1e-12)
    centre2, frame2 = best_fit_plane(points)  # without normals: least variance, up to sign
    assert abs(frame2[2] @ normals[0]) == pytest.approx(1.0)
    np.testing.assert_allclose(frame @ frame.T, np.eye(3), atol=1e-12)


def test_delaunay_of_a_flat_grid_is_the_square():
    points, normals = plane_cloud(spacing=0.002, tilt_deg=20)
    r = reconstruct(points, normals, method="delaunay")
    assert r.method == "delaunay"
    assert r.info["area_m2"] == pytest.approx(0.1 * 0.1, rel=1e-6)
    assert r.info["vertices"] == len(points) and not r.info["watertight"]
    # every vertex is a cloud point: no invented geometry
    assert np.abs(np.asarray(r.mesh.vertices) @ normals[0] - points[0] @ normals[0]).max() < 1e-12


def test_delaunay_of_the_upper_side_of_a_cylinder_is_within_a_tenth_of_a_millimetre():
    rng = np.random.default_rng(1)
    theta, x = rng.uniform(-1.1, 1.1, 8000), rng.uniform(-0.1, 0.1, 8000)
    normals = np.column_stack((np.zeros_like(x), np.sin(theta), np.cos(theta)))
    points = np.column_stack((x, 0.05 * normals[:, 1], 0.05 * normals[:, 2]))
    r = reconstruct(points, normals, method="delaunay")
    truth = trimesh.creation.cylinder(radius=0.05, height=0.2, sections=256)
    truth.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    m = reconstruction_metrics(truth, r.mesh, points, region={"normal": [0, 0, 1], "max_angle_deg": 60})
    assert m["accuracy_m"] < 1e-4 and m["completeness_m"] < 2e-4 and m["coverage"] > 0.99


def test_auto_takes_delaunay_for_a_face_and_surface_for_a_cloud_that_curves_away():
    points, normals = plane_cloud(spacing=0.003, tilt_deg=10)
    normals[:5] = (1.0, 0.0, 0.0)  # a few imprints from a pad rolled over an edge
    assert reconstruct(points, normals, method="auto").method == "delaunay"
    points, normals = sphere_cloud(n=3000, upper_only=True)
    assert reconstruct(points, normals, method="auto").method == "surface"


def test_surface_reconstruction_of_a_sphere_cloud():
    points, normals = sphere_cloud()
    r = reconstruct(points, normals, method="auto")
    assert r.method == "surface"  # normals all around: not a height field
    radius = np.linalg.norm(np.asarray(r.mesh.vertices), axis=1)
    assert np.abs(radius - 0.05).max() < 1.5e-3 and np.abs(radius - 0.05).mean() < 3e-4
    assert r.info["area_m2"] == pytest.approx(4 * np.pi * 0.05**2, rel=0.05)


def test_convex_hull_of_a_sphere_cloud_is_watertight():
    points, normals = sphere_cloud(n=3000)
    r = reconstruct(points, normals, method="hull")
    assert r.info["watertight"]
    assert r.mesh.volume == pytest.approx(4 / 3 * np.pi * 0.05**3, rel=0.03)
    assert np.all(np.linalg.norm(np.asarray(r.mesh.vertices), axis=1) == pytest.approx(0.05))


def test_cleaning_removes_bridges_over_gaps_and_small_pieces():
    a, na = plane_cloud(spacing=0.002, size=0.04)
    b = a + (0.06, 0, 0)  # a second patch 20 mm away
    points = np.vstack((a, b))
    r = reconstruct(points, np.vstack((na, na)), method="delaunay", max_edge_m=0.005)
    tri = r.mesh.triangles
    assert np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max() <= 0.005
    assert r.info["area_m2"] == pytest.approx(2 * 0.04 * 0.04, rel=1e-6)  # no bridge
    small = trimesh.Trimesh([[0, 0, 0], [1e-3, 0, 0], [0, 1e-3, 0]], [[0, 1, 2]])
    both = trimesh.util.concatenate([r.mesh, small.copy().apply_translation((0.5, 0, 0))])
    assert len(clean_mesh(both, max_edge_m=0.005).faces) == len(r.mesh.faces)


def test_reconstruct_checks_its_method_and_survives_tiny_clouds(tmp_path):
    with pytest.raises(ValueError, match="method"):
        reconstruct(np.zeros((10, 3)), method="poisson")
    r = reconstruct(np.array([[0.0, 0, 0], [1e-3, 0, 0]]), method="auto")
    assert r.info["faces"] == 0
    assert set(METHODS) == {"auto", "delaunay", "surface", "hull"}
    points, normals = plane_cloud(spacing=0.005, size=0.02)
    mesh = reconstruct(points, normals, method="delaunay").mesh
    write_surface(tmp_path / "surface.ply", mesh)
    back = trimesh.load(tmp_path / "surface.ply")
    assert len(back.faces) == len(mesh.faces)


def test_bench_reconstruction_reports_each_method():
    figures = bench_reconstruction(n=2000, methods=("delaunay", "hull"))
    assert figures["points"] == 2000 and figures["target_s"] == 2.0
    assert figures["delaunay_s"] > 0 and figures["delaunay_faces"] > 3000
    assert figures["hull_faces"] > 100
