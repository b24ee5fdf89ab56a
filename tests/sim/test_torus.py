"""The torus: its exact signed distance, its scene checks, its imprint on the pad, and a scan of
the shipped ring (``sim/scan_torus.yaml``). What every shape must do is checked for it in
tests/sim/test_shape_conformance.py."""

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from tactile_bt import run_mission
from tactile_bt.control.spatial import make_pose
from tactile_bt.errors import SceneError
from tactile_bt.perception.features import extract, wrap_half_pi
from tactile_bt.sim.objects import object_pose
from tactile_bt.sim.pad import SensorModel, SensorParams
from tactile_bt.sim.scene import load_scene
from tactile_bt.sim.shapes.torus import Torus

REPO = Path(__file__).resolve().parents[2]
R, r = 0.06, 0.025  # the shipped ring's major and minor radius (m)


def ring(**kwargs) -> Torus:
    """The shipped ring lying flat on a table at z = 0, turned 30° about its axis."""
    return Torus(major_radius=R, minor_radius=r, stiffness=1e5, pose=object_pose([0.01, -0.02, r], [0, 0, 30]),
                 **kwargs)


def test_the_signed_distance_is_the_distance_to_the_tube():
    torus = ring()
    centre = np.array([0.01, -0.02, r])
    points = centre + np.array([
        [R, 0, r],            # top of the ring: on the surface
        [0, -R, r + 0.01],    # 10 mm above the top
        [0, 0, 0],            # centre of the hole: R - r from the inner side
        [0, 0, 0.1],          # above the hole
        [R, 0, 0],            # centre of the tube: r deep
        [-(R - r) + 0.002, 0, 0],  # 2 mm into the hole from the inner side
    ])
    expected = [0.0, 0.01, R - r, np.hypot(R, 0.1) - r, -r, 0.002]
    assert_allclose(torus.sdf(points), expected, atol=1e-12)


def test_a_torus_without_a_hole_is_an_error_at_its_minor_radius(tmp_path):
    scene = (REPO / "sim" / "scan_torus.yaml").read_text().replace("minor_radius: 0.025", "minor_radius: 0.07")
    path = tmp_path / "scene.yaml"
    path.write_text(scene)
    line = next(i for i, text in enumerate(scene.splitlines(), start=1) if "minor_radius" in text)
    with pytest.raises(SceneError, match=rf"^{path}:{line}:\d+: objects\.0\.minor_radius: .*hole"):
        load_scene(path)
    with pytest.raises(ValueError, match="hole"):
        Torus(major_radius=0.02, minor_radius=0.02)


@pytest.mark.parametrize("where_deg", [0, 90, 200])
def test_the_pad_on_top_of_the_ring_sees_a_line_along_the_ring(where_deg):
    """The top of the ring is curved across the tube (radius r) and only gently along the ring
    (radius R + r): the imprint is a line along the ring's tangent (within 6°: the line bends
    with the ring over the pad's 80 mm and is two tactels wide)."""
    torus = ring()
    phi = np.deg2rad(where_deg + 30)  # the torus is turned 30°
    top = np.array([0.01, -0.02, 2 * r]) + R * np.array([np.cos(phi), np.sin(phi), 0])
    T = make_pose(Rotation.from_euler("xyz", [180, 0, 0], degrees=True), top - [0, 0, 4e-4])
    sensor = SensorModel(SensorParams(), np.random.default_rng(0))
    f = extract(sensor.force_image(T, [torus])[0], method="moments")
    assert f.in_contact and f.area < 120  # a line a few tactels wide, not a patch
    tangent_s = T[:3, :3].T @ [-np.sin(phi), np.cos(phi), 0]
    expected = np.arctan2(tangent_s[1], tangent_s[0])
    assert abs(wrap_half_pi(f.orientation - expected)) < np.deg2rad(6)


def test_a_scan_of_the_shipped_ring_records_contacts_on_its_surface():
    scene = load_scene(REPO / "sim" / "scan_torus.yaml")
    result = run_mission(REPO / "trees" / "scan_object.yaml", scene, duration=6.0, reconstruct="none")
    assert result.report["status"] in ("running", "completed"), result.report.get("reason")
    points = result.contacts[:, :3]
    assert len(points) > 200
    torus = scene.objects[0]
    assert isinstance(torus, Torus)
    # the contacts lie on the ring, not on the table: within the pad's indentation and the flat
    # pad's offset from a curved surface at the centre of pressure
    distance = np.abs(torus.sdf(points))
    assert np.max(distance) < 2e-3 and np.mean(distance) < 5e-4
    assert np.ptp(points[:, 0]) > 0.01 or np.ptp(points[:, 1]) > 0.01  # it has moved along the ring
