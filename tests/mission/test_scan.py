"""Surface scans: the contact cloud (imprint points through a known pose, voxel thinning), the
scan leaves (world-frame guidance, the end of a stripe, coverage that stops growing) and the
accuracy metrics on hand-checkable cases."""


import numpy as np
import py_trees
import pytest
import trimesh
from numpy.testing import assert_allclose
from py_trees.common import Status
from scipy.spatial.transform import Rotation

from tactile_bt import defaults
from tactile_bt.contacts.cloud import ContactCloud
from tactile_bt.tree.behaviours import CoverageStalled, RecordContacts, ScanDirection
from tactile_bt.tree.behaviours.contact_points import imprint_points
from tactile_bt.perception.features import extract
from tactile_bt.sim.region import check_region
from tactile_bt.mission.accuracy import (contact_continuity, reconstruction_metrics, region_mask,
                                     sample_surface, true_surface)
from tactile_bt.sim.pad import SensorModel, SensorParams
from tactile_bt.sim.shapes import Box, Cylinder, Sphere
from tactile_bt.sim.objects import object_pose
from tactile_bt.control.spatial import make_pose
from tactile_bt.testing import LeafHarness, make_features
from scan_helpers import ticks_until_done

DT = 1.0 / 250.0
DOWN = Rotation.from_euler("x", 180, degrees=True)  # pad facing down: x_s = x_g, y_s = -y_g



def pressed_on_box(x_centre: float, box: Box | None = None, depth: float = 2e-4):
    """Noise-free force image and pose of the pad pressed ``depth`` into the top face (z = 0) of
    a 100 mm box whose +x face is at x = 0, with the pad centre at ``x_centre``."""
    box = box or Box(size=(0.1, 0.1, 0.05), stiffness=1e5, pose=object_pose((-0.05, 0.0, -0.025)))
    pose = make_pose(DOWN, (x_centre, 0.0, -depth))
    return noise_free_force(pose, box), pose


def noise_free_force(pose: np.ndarray, obj) -> np.ndarray:
    """The simulated pad's force image (N per tactel) at ``pose`` against ``obj``, without noise
    or calibration spread."""
    params = SensorParams(noise_counts=0, noise_relative=0, noise_common=0, calibration_spread=0)
    force, _ = SensorModel(params, np.random.default_rng(0)).force_image(pose, [obj])
    return force


# --------------------------------------------------------------------------------- contact cloud


def test_imprint_of_a_pad_half_over_an_edge_ends_at_the_edge():
    force, pose = pressed_on_box(0.0)  # the pad's +x half hangs over the edge at x = 0
    f = extract(force)
    local, pressure = imprint_points(f)
    world = local @ pose[:3, :3].T + pose[:3, 3]
    assert world[:, 0].max() == pytest.approx(0.0, abs=1.5e-3)  # the half-peak contour is the edge
    assert world[:, 0].min() < -0.035                          # the whole face under the pad
    assert np.all(np.abs(world[:, 1]) <= 0.04) and np.all(pressure > 0)
    # a full contact covers the pad on a 2.5 mm grid
    full, _ = pressed_on_box(-0.045)
    points, _ = imprint_points(extract(full))
    assert len(points) == 32 * 32
    assert_allclose(points[:, :2].min(axis=0), [-0.03875, -0.03875])


def _edge_under_a_tilted_pad(rng):
    """Noise-free force image and pose of the pad tilted 25–70° over the +x edge of
    :func:`pressed_on_box`'s box, turned about its normal and shifted in its plane by part of a
    tactel, pressed 0.5–2.5 mm in, and the box."""
    box = Box(size=(0.1, 0.1, 0.05), stiffness=1e5, pose=object_pose((-0.05, 0.0, -0.025)))
    tilt, phase, yaw, depth = rng.uniform(25, 70), rng.uniform(0, 0.005), rng.uniform(0, 90), rng.uniform(5e-4, 2.5e-3)
    R = Rotation.from_euler("y", tilt, degrees=True) * DOWN * Rotation.from_euler("z", yaw, degrees=True)
    n = R.apply([0.0, 0.0, 1.0])
    shift = R.apply([phase, 0.3 * phase, 0.0])
    pose = make_pose(R, n * depth + shift - n * (n @ shift))
    return noise_free_force(pose, box), pose, box


def test_the_imprint_of_an_edge_under_a_tilted_pad_lies_on_the_edge_not_beside_it():
    rng = np.random.default_rng(7)
    beside, on = [], []
    for _ in range(40):
        force, pose, box = _edge_under_a_tilted_pad(rng)
        f = extract(force)
        if not f.in_contact:
            continue
        for spread, out in ((0.0, beside), (defaults.IMPRINT_SPREAD_PX, on)):
            local, _ = imprint_points(f, spread_px=spread)
            out.append(box.sdf(local @ pose[:3, :3].T + pose[:3, 3]))
    beside, on = np.concatenate(beside), np.concatenate(on)
    assert np.percentile(beside, 99) > 2e-3  # the foam's spread: samples on the pad's plane in the air
    assert on.max() < 1e-3 and np.percentile(on, 99) < 0.5e-3  # drawn in to the edge
    assert on.min() > -2.6e-3  # inside by no more than the pad pressed in


def test_record_contacts_draws_the_imprint_in_when_told_the_sensor_s_spread():
    force, pose, _ = _edge_under_a_tilted_pad(np.random.default_rng(3))
    f = extract(force)
    h = LeafHarness(RecordContacts(point="region", region_spread_px=defaults.IMPRINT_SPREAD_PX), dt=DT, pose=pose)
    h.tick(f)
    local, _ = imprint_points(f, spread_px=defaults.IMPRINT_SPREAD_PX)
    assert_allclose(h.contacts.points, local @ pose[:3, :3].T + pose[:3, 3], atol=1e-12)
    assert np.max(np.linalg.norm(local - imprint_points(f)[0], axis=1)) > 1e-3  # drawn in


@pytest.mark.parametrize("x_centre", [0.0, -0.045, -0.02])
def test_a_flat_contact_keeps_its_whole_imprint(x_centre):
    f = extract(pressed_on_box(x_centre)[0])
    spread = defaults.IMPRINT_SPREAD_PX
    assert_allclose(imprint_points(f, spread_px=spread)[0], imprint_points(f)[0], atol=1e-12)


@pytest.mark.parametrize("radius", [0.03, 0.06, 0.1])
def test_a_curved_contact_keeps_most_of_its_width(radius):
    cylinder = Cylinder(stiffness=1e5, radius=radius, length=0.3, pose=object_pose((0.0, 0.0, -radius), (90, 0, 0)))
    pose = make_pose(DOWN, (0.0013, 0.0, -1e-3))
    f = extract(noise_free_force(pose, cylinder))
    width = np.ptp(imprint_points(f)[0][:, 1])
    local, _ = imprint_points(f, spread_px=defaults.IMPRINT_SPREAD_PX)
    assert np.ptp(local[:, 1]) >= 0.85 * width  # across the cylinder: the contact is that wide
    assert np.all(cylinder.sdf(local @ pose[:3, :3].T + pose[:3, 3]) <= 0.0)


def test_record_region_points_go_through_the_known_pose():
    force, _ = pressed_on_box(0.0)
    f = extract(force)
    R = Rotation.from_euler("xyz", [170, 20, 35], degrees=True)
    T = make_pose(R, (0.3, -0.2, 0.5))
    h = LeafHarness(RecordContacts(point="region"), dt=DT, pose=T)
    h.tick(f)
    local, _ = imprint_points(f)
    assert len(h.contacts) == len(local) > 100
    assert_allclose(h.contacts.points, local @ T[:3, :3].T + T[:3, 3], atol=1e-12)
    assert_allclose(h.contacts.normals, np.tile(-T[:3, 2], (len(local), 1)), atol=1e-12)
    assert np.all(h.contacts.data[:, 7] == 0.0)


def test_voxel_thinning_keeps_one_sample_per_voxel_across_recorders():
    force, pose = pressed_on_box(-0.045)
    f = extract(force)
    first = LeafHarness(RecordContacts(point="region", voxel_m=0.005), dt=DT, pose=pose)
    cloud = first.contacts
    first.tick(f)
    n = len(cloud)
    # 80 mm of pad at 5 mm voxels: 16 x 16 voxels (the points lie in one z layer)
    assert n == 256
    keys = np.floor(cloud.points / 0.005).astype(int)
    assert len(np.unique(keys, axis=0)) == n
    first.tick(f)  # the same imprint again: nothing new
    assert len(cloud) == n
    # a second recorder of the same mission shares the voxels
    py_trees.blackboard.Blackboard.clear()
    second = LeafHarness(RecordContacts(point="region", voxel_m=0.005), dt=DT, pose=pose)
    second.behaviour.contacts = cloud
    second.tick(f)
    assert len(cloud) == n


def test_region_recording_waits_until_the_pad_has_moved():
    force, pose = pressed_on_box(-0.045)
    f = extract(force)
    h = LeafHarness(RecordContacts(point="region", min_spacing_m=0.002), dt=DT, pose=pose)
    h.tick(f)
    n = len(h.contacts)
    moved = pose.copy()
    moved[0, 3] += 0.001
    h.set_pose(moved)
    h.tick(f)
    assert len(h.contacts) == n          # 1 mm < 2 mm: skipped
    moved[0, 3] += 0.0015
    h.set_pose(moved)
    h.tick(f)
    assert len(h.contacts) == 2 * n      # 2.5 mm: recorded


def test_contact_cloud_extend_and_fresh():
    cloud = ContactCloud(capacity=2)
    cloud.extend(np.arange(15.0).reshape(5, 3), [0, 0, 1], np.arange(5.0), 1.5)
    assert len(cloud) == 5 and cloud.data.shape == (5, 8)
    assert_allclose(cloud.data[:, 6], np.arange(5.0))
    assert np.all(cloud.data[:, 7] == 1.5) and np.all(cloud.normals == [0, 0, 1])
    mask = cloud.fresh(np.array([[0.0, 0, 0], [0.0004, 0, 0], [0.0011, 0, 0], [-0.0001, 0, 0]]), 0.001)
    assert mask.tolist() == [True, False, True, True]


def test_record_contacts_rejects_bad_scan_parameters():
    with pytest.raises(ValueError, match="region_level"):
        RecordContacts(region_level=0.0)
    with pytest.raises(ValueError, match="reconstruct"):
        RecordContacts(reconstruct="poisson")
    with pytest.raises(ValueError, match="voxel_m"):
        RecordContacts(voxel_m=-1.0)


# --------------------------------------------------------------------------------- scan leaves


def test_scan_direction_projects_a_world_direction_into_the_sensor_frame():
    h = LeafHarness(ScanDirection(direction=[0, 1, 0], speed_mps=0.02), dt=DT, pose=make_pose(DOWN, (0, 0, 0)))
    assert h.tick(make_features()) == Status.RUNNING
    twist = py_trees.blackboard.Blackboard.storage["/scan/guidance"]
    assert_allclose(twist, [0, -0.02, 0, 0, 0, 0], atol=1e-15)  # world +y is sensor -y
    # tilted 30° about world x: world +y is no longer in the pad plane; its projection is
    tilted = make_pose(Rotation.from_euler("x", 30, degrees=True) * DOWN, (0, 0, 0))
    leaf = ScanDirection(direction=[0, 1, 0], speed_mps=0.02)
    assert_allclose(np.linalg.norm(leaf.guidance(tilted)[:2]), 0.02)
    assert leaf.guidance(tilted)[2] == 0.0
    v_world = tilted[:3, :3] @ leaf.guidance(tilted)[:3]
    assert v_world[1] > 0 and abs(v_world @ tilted[:3, 2]) < 1e-15
    # along the pad normal: no tangential direction, no guidance
    assert_allclose(ScanDirection(direction=[0, 0, 1]).guidance(make_pose(DOWN, (0, 0, 0))), np.zeros(6))


def test_coverage_stalled_when_the_cloud_stops_growing():
    h = LeafHarness(CoverageStalled(window_s=1.0, min_growth=0.1, min_samples=10), dt=DT)
    cloud = h.contacts
    for k in range(2 * 250):
        cloud.append([k * 1e-3, 0, 0], [0, 0, 1], 2000.0, k * DT)  # grows every cycle
        assert h.tick(make_features()) == Status.RUNNING
    k, status = ticks_until_done(h, 400)  # no growth: SUCCESS once the window holds none
    assert status == Status.SUCCESS and k == pytest.approx(250 * (1 - 0.1 * 500 / 500), abs=30)
    assert "stalled" in h.behaviour.feedback_message


# --------------------------------------------------------------------------------- metrics


def square(z: float, x0=-0.05, x1=0.05, y0=-0.05, y1=0.05) -> trimesh.Trimesh:
    return trimesh.Trimesh([[x0, y0, z], [x1, y0, z], [x1, y1, z], [x0, y1, z]], [[0, 1, 2], [0, 2, 3]])


TOP = {"normal": [0, 0, 1], "max_angle_deg": 10}


def test_metrics_of_a_surface_0_5_mm_above_the_true_face():
    box = trimesh.creation.box(extents=(0.1, 0.1, 0.05))
    box.apply_translation((0, 0, -0.025))  # top face at z = 0
    m = reconstruction_metrics(box, square(0.0005), region=TOP)
    assert m["region_area_m2"] == pytest.approx(0.01)
    for key in ("accuracy_m", "completeness_m", "chamfer_m", "hausdorff_m"):
        assert m[key] == pytest.approx(0.0005, abs=1e-9), key
    assert m["fscore_1mm"] == 1.0 and m["fscore_2mm"] == 1.0
    m = reconstruction_metrics(box, square(0.0015), region=TOP)
    assert m["fscore_1mm"] == 0.0 and m["fscore_2mm"] == 1.0


def test_metrics_of_a_surface_that_covers_half_the_face():
    box = trimesh.creation.box(extents=(0.1, 0.1, 0.05))
    box.apply_translation((0, 0, -0.025))
    m = reconstruction_metrics(box, square(0.0, x1=0.0), region=TOP)
    assert m["accuracy_m"] == pytest.approx(0.0, abs=1e-9)
    # the uncovered half lies on average 25 mm from the covered half's border: 12.5 mm over all
    assert m["completeness_m"] == pytest.approx(0.0125, rel=0.02)
    assert m["chamfer_m"] == pytest.approx(0.00625, rel=0.02)
    assert m["hausdorff_m"] == pytest.approx(0.05, rel=0.02)
    # precision 1, recall about 0.5 (plus the 1 mm band next to the border)
    assert m["fscore_1mm"] == pytest.approx(2 * 0.51 / 1.51, abs=0.01)


def test_coverage_counts_the_true_surface_within_2_mm_of_a_contact():
    box = trimesh.creation.box(extents=(0.1, 0.1, 0.05))
    box.apply_translation((0, 0, -0.025))
    g = np.arange(-0.05, 0.0 + 1e-9, 0.001)
    contacts = np.array([[x, y, 0.0] for x in g for y in np.arange(-0.05, 0.05 + 1e-9, 0.001)])
    m = reconstruction_metrics(box, None, contacts, region=TOP)
    assert m["accuracy_m"] is None
    assert m["coverage"] == pytest.approx(0.52, abs=0.005)              # x < 2 mm of 100 mm
    # the whole box: that part of the top, and 2 mm strips of the three side faces it borders
    assert m["coverage_total"] == pytest.approx((0.0052 + 0.1 * 0.002 + 2 * 0.052 * 0.002) / box.area, abs=0.002)


def test_sampling_and_regions():
    box = trimesh.creation.box(extents=(0.16, 0.12, 0.06))
    points, normals, weights = sample_surface(box, 0.001)
    assert weights.sum() == pytest.approx(box.area)
    assert len(points) == pytest.approx(box.area / 1e-6, rel=0.1)
    top = region_mask(points, normals, TOP)
    assert weights[top].sum() == pytest.approx(0.16 * 0.12)
    inside = region_mask(points, normals, {"box": [[-1, -1, -1], [0, 1, 1]]})
    assert weights[inside].sum() == pytest.approx(box.area / 2, rel=1e-3)
    with pytest.raises(ValueError, match="unknown key"):
        check_region({"normals": [0, 0, 1]})


@pytest.mark.parametrize("obj", [
    Box(size=(0.1, 0.06, 0.04), pose=object_pose((0.1, 0, 0.02), (0, 0, 30))),
    Sphere(radius=0.05, pose=object_pose((0, 0.1, 0.05))),
    Cylinder(radius=0.03, length=0.2, pose=object_pose((0, 0, 0.03), (0, 0, 90))),
], ids=["box", "sphere", "cylinder"])
def test_true_surfaces_lie_on_the_simulated_objects(obj):
    mesh = true_surface(obj)
    points, _, _ = sample_surface(mesh, 0.003)
    assert np.abs(obj.sdf(points)).max() < 1e-4  # tessellation error only
    assert mesh.is_watertight


def test_contact_continuity_finds_the_longest_gap():
    t = np.arange(0, 2.0, 0.004)
    touching = np.ones_like(t)
    touching[:50] = 0            # before the first contact: not a gap
    touching[200:225] = 0        # 0.1 s without contact
    c = contact_continuity(t, touching)
    assert c["first_contact_s"] == pytest.approx(0.2)
    assert c["longest_gap_s"] == pytest.approx(0.1)
    assert c["contact_share"] == pytest.approx(1 - 25 / 450)
    assert contact_continuity(t, np.zeros_like(t))["contact_share"] is None


def test_imprint_helpers_match_scipy_and_numpy():
    """The imprint's dilation and peak percentile are ``ndimage.binary_dilation`` and
    ``numpy.percentile``, written out for speed: the same results."""
    from scipy import ndimage

    from tactile_bt.tree.behaviours.contact_points import _dilated, _percentile

    rng = np.random.default_rng(3)
    for _ in range(300):
        mask = rng.random((int(rng.integers(1, 18)), int(rng.integers(1, 18)))) < rng.random()
        np.testing.assert_array_equal(_dilated(mask), ndimage.binary_dilation(mask))
        values = rng.exponential(size=int(rng.integers(1, 257))) * 10.0 ** rng.uniform(-3, 1)
        if rng.random() < 0.3:
            values = np.round(values, 1)  # ties
        for q in (0, 10, 50, 90, 99.5, 100):
            assert_allclose(_percentile(values.copy(), q), np.percentile(values, q), rtol=1e-12, atol=0)
