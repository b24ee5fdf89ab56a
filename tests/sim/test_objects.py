"""Simulated objects: signed distances of the primitives and of meshes, poses, bounds, contact
through the pad model (flat box, pen line, soft against rigid), the scenes in sim/ and their
validation errors."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_less
from scipy.spatial.transform import Rotation

from tactile_bt import defaults, load_tree, run_mission
from tactile_bt.perception.features import extract, wrap_half_pi
from tactile_bt.sim.objects import CONTACT_REFERENCE_AREA_M2, Cable, SimObject, Table, object_pose
from tactile_bt.sim.scene import load_scene
from tactile_bt.errors import SceneError
from tactile_bt.sim.pad import SensorModel, SensorParams
from tactile_bt.sim.shapes import Box, Cylinder, Sphere
from tactile_bt.control.spatial import make_pose

REPO = Path(__file__).resolve().parents[2]
SIM = REPO / "sim"
MESH = SIM / "meshes" / "unknown_object.ply"
PITCH = defaults.PITCH_M
FACE_DOWN = Rotation.from_euler("x", 180, degrees=True)
NEW_SCENES = ["pen", "toy_box", "soft_ball", "edge", "object"]


def pad_down(x=0.0, y=0.0, z=0.0, yaw_deg=0.0):
    """Pad pose with its normal pointing down (the scenes' rpy_deg [180, 0, yaw])."""
    return make_pose(Rotation.from_euler("xyz", [180, 0, yaw_deg], degrees=True), (x, y, z))


def quiet_model(**params):
    return SensorModel(SensorParams(**params), np.random.default_rng(0))


def write(tmp_path, text, name="scene.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def mesh_object():
    from tactile_bt.sim.mesh_object import MeshObject

    return MeshObject(path=str(MESH), stiffness=1e5)


# --------------------------------------------------------------------------------- primitives


def test_box_signed_distance_at_hand_checked_points():
    box = Box(size=(0.2, 0.1, 0.04))
    pts = np.array([
        [0.0, 0.0, 0.0],  # centre: nearest face is z, 20 mm away
        [0.15, 0.0, 0.0],  # 50 mm beyond the +x face
        [0.13, 0.09, 0.0],  # beyond the x-y edge: hypot(30, 40) mm
        [0.13, 0.09, 0.045],  # beyond the corner: |(30, 40, 25)| mm
        [0.1, 0.0, 0.0],  # on the +x face
        [0.09, 0.0, 0.0],  # inside, 10 mm from +x but 20 mm from z
        [0.099, 0.045, 0.0],  # inside near the edge: 1 mm from +x
    ])
    expected = [-0.02, 0.05, 0.05, np.sqrt(0.03**2 + 0.04**2 + 0.025**2), 0.0, -0.01, -0.001]
    assert_allclose(box.sdf(pts), expected, atol=1e-15)


def test_sphere_signed_distance_at_hand_checked_points():
    ball = Sphere(radius=0.05, pose=object_pose([0.0, 0.0, 0.05]))
    pts = np.array([[0.0, 0.0, 0.05], [0.08, 0.0, 0.05], [0.0, 0.0, 0.1], [0.0, 0.03, 0.05], [0.0, 0.0, 0.0]])
    assert_allclose(ball.sdf(pts), [-0.05, 0.03, 0.0, -0.02, 0.0], atol=1e-15)


def test_cylinder_signed_distance_at_hand_checked_points():
    pen = Cylinder(radius=0.01, length=0.1)  # axis along x, ends at x = ±0.05
    pts = np.array([
        [0.0, 0.0, 0.0],  # on the axis, 10 mm from the mantle
        [0.0, 0.03, 0.0],  # 20 mm off the mantle
        [0.02, 0.0, -0.025],  # 15 mm below
        [0.08, 0.0, 0.0],  # 30 mm beyond an end
        [0.06, 0.013, 0.0],  # beyond the rim: hypot(10, 3) mm
        [0.045, 0.0, 0.0],  # inside, 5 mm from the flat end
        [0.0, 0.006, 0.008],  # on the mantle
    ])
    expected = [-0.01, 0.02, 0.015, 0.03, np.hypot(0.01, 0.003), -0.005, 0.0]
    assert_allclose(pen.sdf(pts), expected, atol=1e-15)


def test_table_and_bounds_of_the_primitives():
    assert_allclose(Table(height=0.02).sdf(np.array([[1.0, -3.0, 0.05], [0.0, 0.0, 0.0]])), [0.03, -0.02])
    assert_allclose(Box(size=(0.2, 0.1, 0.04)).bounds(), [[-0.1, -0.05, -0.02], [0.1, 0.05, 0.02]])
    assert_allclose(Sphere(radius=0.05).bounds(), [[-0.05] * 3, [0.05] * 3])
    assert_allclose(Cylinder(radius=0.01, length=0.1).bounds(), [[-0.05, -0.01, -0.01], [0.05, 0.01, 0.01]])


@pytest.mark.parametrize("bad", [
    lambda: Box(size=(0.1, -0.1, 0.1)),
    lambda: Box(size=(0.1, 0.1)),
    lambda: Sphere(radius=0.0),
    lambda: Cylinder(radius=0.01, length=-1.0),
    lambda: Sphere(radius=0.1, pose=np.diag([1.0, 1.0, -1.0, 1.0])),  # a reflection
])
def test_bad_dimensions_and_poses_are_refused(bad):
    with pytest.raises(ValueError):
        bad()


def _posed_primitives():
    return [
        Box(size=(0.2, 0.1, 0.04), pose=object_pose([0.01, -0.02, 0.03], [10, 20, 30])),
        Sphere(radius=0.05, pose=object_pose([0.0, 0.01, 0.02])),
        Cylinder(radius=0.01, length=0.1, pose=object_pose([0.02, 0.0, 0.0], [0, 35, 60])),
        Table(height=0.01, pose=object_pose([0.0, 0.0, 0.005], [5, -3, 0])),
    ]


@pytest.mark.parametrize("obj", _posed_primitives(), ids=["box", "sphere", "cylinder", "tilted-table"])
def test_primitive_sdf_is_1_lipschitz(obj):
    rng = np.random.default_rng(1)
    p = rng.uniform(-0.15, 0.15, (20000, 3))
    q = p + rng.normal(0.0, 0.01, p.shape) * rng.uniform(0, 3, (len(p), 1))
    assert np.all(np.abs(obj.sdf(p) - obj.sdf(q)) <= np.linalg.norm(p - q, axis=1) + 1e-12)


@pytest.mark.parametrize("obj", _posed_primitives()[:3], ids=["box", "sphere", "cylinder"])
def test_world_bounds_contain_the_posed_object(obj):
    rng = np.random.default_rng(2)
    p = obj.pose[:3, 3] + rng.uniform(-0.12, 0.12, (200000, 3)) * (0.6 if isinstance(obj, Cylinder) else 1.0)
    inside = p[obj.sdf(p) <= 0]
    assert len(inside) > 1000
    b = obj.bounds()
    assert np.all(inside >= b[0] - 1e-12) and np.all(inside <= b[1] + 1e-12)
    # and tight: the object reaches close to every face of its box
    assert_allclose(inside.min(axis=0), b[0], atol=0.01)
    assert_allclose(inside.max(axis=0), b[1], atol=0.01)


def test_pose_transforms_world_points_into_the_object_frame():
    T = object_pose([0.1, -0.2, 0.3], [30, -40, 75])
    box = Box(size=(0.2, 0.1, 0.04), pose=T)
    local = np.random.default_rng(3).uniform(-0.2, 0.2, (500, 3))
    world = local @ T[:3, :3].T + T[:3, 3]
    assert_allclose(box.sdf(world), Box(size=(0.2, 0.1, 0.04)).sdf(local), atol=1e-15)
    # a yawed pen: its axis along world y after 90° about z
    pen = Cylinder(radius=0.005, length=0.1, pose=object_pose([0.0, 0.0, 0.005], [0, 0, 90]))
    assert_allclose(pen.sdf(np.array([[0.0, 0.08, 0.005], [0.08, 0.0, 0.005], [0.0, 0.0, 0.02]])),
                    [0.03, 0.075, 0.01], atol=1e-15)
    # the object_pose convention is the mount's: extrinsic x-y-z
    assert_allclose(T[:3, :3], Rotation.from_euler("xyz", [30, -40, 75], degrees=True).as_matrix())


def test_moved_turns_about_the_object_origin_then_shifts_and_leaves_the_original():
    box = Box(size=(0.2, 0.02, 0.02), pose=object_pose([0.1, 0.0, 0.0]))
    moved = box.moved(translate=[0.0, 0.05, 0.0], rotate_deg=[0, 0, 90])
    # the long axis now along y, centred at (0.1, 0.05, 0)
    assert_allclose(moved.pose[:3, 3], [0.1, 0.05, 0.0])
    assert_allclose(moved.sdf(np.array([[0.1, 0.05 + 0.1, 0.0], [0.1 + 0.01, 0.05, 0.0]])), [0.0, 0.0], atol=1e-15)
    assert_allclose(moved.bounds(), [[0.09, -0.05, -0.01], [0.11, 0.15, 0.01]], atol=1e-15)
    assert_allclose(box.pose[:3, 3], [0.1, 0.0, 0.0])  # the original stays
    assert box.sdf(np.array([[0.2, 0.0, 0.0]]))[0] == pytest.approx(0.0)


def test_cable_with_a_pose_keeps_its_geometry_and_metrics():
    path = np.array([[0.0, 0.0], [0.1, 0.0]])
    T = object_pose([0.02, 0.03, 0.0], [0, 0, 90])
    plain = Cable(path=path, radius=0.003)
    posed = Cable(path=path, radius=0.003, pose=T)
    local = np.array([[0.05, 0.002, 0.003], [0.05, 0.0, 0.01], [0.02, -0.01, 0.0]])
    world = local @ T[:3, :3].T + T[:3, 3]
    assert_allclose(posed.sdf(world), plain.sdf(local), atol=1e-12)
    assert_allclose(posed.distance_to_centreline(world[:, :2]), plain.distance_to_centreline(local[:, :2]), atol=1e-12)
    assert_allclose(posed.centreline_world()[:, :2], [[0.02, 0.03], [0.02, 0.13]], atol=1e-12)
    b = posed.bounds()
    assert_allclose(b[:, :2], [[0.017, 0.03 - 0.003], [0.023, 0.13 + 0.003]], atol=1e-12)


def test_stiffness_per_area_uses_the_reference_area():
    assert Sphere(radius=0.05, stiffness=1e2).area_stiffness == pytest.approx(1e2 / CONTACT_REFERENCE_AREA_M2)


# --------------------------------------------------------------------------------- meshes


def _winding_number(vertices, faces, q):
    """Generalised winding number (1 inside, 0 outside) of points q, brute force."""
    out = []
    for chunk in np.array_split(q, max(1, len(q) // 20)):
        a = vertices[faces][None] - chunk[:, None, None, :]
        n = np.linalg.norm(a, axis=3)
        det = np.einsum("pfi,pfi->pf", a[:, :, 0], np.cross(a[:, :, 1], a[:, :, 2]))
        dots = [np.einsum("pfi,pfi->pf", a[:, :, i], a[:, :, j]) for i, j in ((0, 1), (1, 2), (2, 0))]
        den = n[..., 0] * n[..., 1] * n[..., 2] + dots[0] * n[..., 2] + dots[1] * n[..., 0] + dots[2] * n[..., 1]
        out.append(2 * np.arctan2(det, den).sum(axis=1) / (4 * np.pi))
    return np.concatenate(out)


def test_mesh_sdf_matches_trimesh_near_the_surface(mesh_object):
    import trimesh

    mesh = trimesh.load(MESH, process=True)
    rng = np.random.default_rng(4)
    surface, _ = trimesh.sample.sample_surface(mesh, 150, seed=5)
    q = surface + rng.normal(0.0, 2.5e-3, surface.shape)
    _, unsigned, _ = trimesh.proximity.closest_point_naive(mesh, q)
    inside = _winding_number(np.asarray(mesh.vertices), np.asarray(mesh.faces), q) > 0.5
    reference = np.where(inside, -unsigned, unsigned)
    sdf = mesh_object.sdf(q)
    assert_array_less(0, np.abs(reference))  # no point exactly on the surface
    assert np.all(np.sign(sdf) == np.sign(reference))
    # exact on the grid points; trilinear in between: a few µm, up to ~0.2 mm at the base's rim
    assert_allclose(sdf, reference, atol=2.5e-4)
    away = q[:, 2] > 0.01  # away from the sharp rim of the flat base
    assert_allclose(sdf[away], reference[away], atol=3e-5)


def test_sphere_mesh_against_the_analytic_sphere():
    import trimesh

    from tactile_bt.sim.mesh_object import NEAR_M, MeshObject

    R = 0.05
    ico = trimesh.creation.icosphere(subdivisions=4, radius=R)
    T = object_pose([0.01, 0.02, 0.03], [20, 0, 45])
    obj = MeshObject.from_arrays(ico.vertices, ico.faces, resolution=1e-3, pose=T)
    ball = Sphere(radius=R, pose=T)
    rng = np.random.default_rng(6)
    d = rng.normal(size=(2000, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    q = T[:3, 3] + d * rng.uniform(R - NEAR_M, R + NEAR_M, (len(d), 1))
    # the flat facets lie up to R (1 - cos(edge/2R)) ≈ 0.03 mm inside the sphere
    assert_allclose(obj.sdf(q), ball.sdf(q), atol=8e-5)
    # deeper inside within a few tenths of a cell
    q = T[:3, 3] + d * rng.uniform(0.0, R - NEAR_M, (len(d), 1))
    assert_allclose(obj.sdf(q), ball.sdf(q), atol=0.4 * obj.grid.h)
    # farther out, a lower bound within two cells
    q = T[:3, 3] + d * rng.uniform(R + NEAR_M + 2e-3, R + 0.05, (len(d), 1))
    s, exact = obj.sdf(q), ball.sdf(q)
    assert np.all(s <= exact + 8e-5)
    inside_grid = np.all((obj.to_local(q) >= obj.grid.lo) & (obj.to_local(q) <= obj.grid.hi), axis=1)
    assert inside_grid.sum() > 100
    assert np.all(s[inside_grid] >= exact[inside_grid] - 2.0 * obj.grid.h)  # h + half a diagonal


def test_mesh_sdf_is_1_lipschitz_near_the_surface_and_conservative_far_away(mesh_object):
    from tactile_bt.sim.mesh_object import NEAR_M

    rng = np.random.default_rng(7)
    b = mesh_object.bounds()
    p = rng.uniform(b[0] - 0.01, b[1] + 0.01, (100000, 3))
    q = p + rng.normal(0.0, 2e-3, p.shape)
    sp, sq = mesh_object.sdf(p), mesh_object.sdf(q)
    step = np.linalg.norm(p - q, axis=1)
    # outside, within the near band: 1-Lipschitz up to the interpolation (µm)
    near = (sp > 0) & (sq > 0) & (sp < NEAR_M) & (sq < NEAR_M)
    assert near.sum() > 1000
    assert np.all(np.abs(sp - sq)[near] <= step[near] + 2e-5)
    # inside: off by little more near the medial axis and the rim
    inner = (sp < 0) & (sq < 0)
    assert np.all(np.abs(sp - sq)[inner] <= step[inner] + 3e-4)
    # far away (beyond the grid) the distance is a lower bound of the true one
    far = np.array([[0.3, 0.0, 0.0], [0.0, -0.2, 0.1], [0.1, 0.1, -0.1]])
    import trimesh

    mesh = trimesh.load(MESH, process=True)
    _, true, _ = trimesh.proximity.closest_point_naive(mesh, far)
    s = mesh_object.sdf(far)
    assert np.all(s <= true) and np.all(s > 0.5 * true)


def test_mesh_grid_is_built_once_and_cached():
    from tactile_bt.sim import mesh_object as mo

    a = load_scene(SIM / "object.yaml").objects[0]
    b = load_scene(SIM / "object.yaml").objects[0]
    assert a.grid is b.grid  # the second load reuses the grid (its build time is in the bench)
    assert a.grid.build_time_s > 0.0
    assert MESH.stat().st_size < 1_000_000
    assert mo.mesh_grid(MESH, 1.0, 1e-3) is a.grid


def test_a_scene_without_a_mesh_does_not_import_trimesh():
    code = ("import sys; from tactile_bt.sim.scene import load_scene; "
            f"s = load_scene({str(SIM / 'cable.yaml')!r}); import numpy as np; "
            "w = s.build_world(np.random.default_rng(0)); w.sense(); "
            "print('trimesh' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


# --------------------------------------------------------------------------------- contact


def test_pad_pressed_flat_on_a_box_gives_a_uniform_image():
    sensor = quiet_model()
    box = Box(size=(0.16, 0.12, 0.06), stiffness=5e4, pose=object_pose([0.0, 0.0, 0.03], [0, 0, 10]))
    depth = 0.2e-3
    force, deepest = sensor.force_image(pad_down(0.003, -0.002, 0.06 - depth, yaw_deg=25), [box])
    assert deepest == pytest.approx(depth)
    k = 1.0 / (1.0 / sensor.params.foam_stiffness + 1.0 / box.area_stiffness)
    expected = k * depth * PITCH**2
    r = max(1, int(np.ceil(2.5 * sensor.params.foam_spread)))
    assert_allclose(force[r:-r, r:-r], expected, rtol=1e-9)
    assert np.ptp(force[1:-1, 1:-1]) <= 0.03 * force[1:-1, 1:-1].mean()
    f = extract(force)
    assert f.area == 256 and f.pressure == pytest.approx(force.sum() / (256 * PITCH**2))


@pytest.mark.parametrize("pen_yaw,pad_yaw", [(0, 0), (30, 0), (45, 10), (60, 0), (90, 0), (120, -20), (150, 0)])
def test_pen_gives_a_line_along_its_axis(pen_yaw, pad_yaw):
    sensor = quiet_model()
    r = 0.004
    pen = Cylinder(radius=r, length=0.14, stiffness=1e7, pose=object_pose([0.0, 0.0, r], [0, 0, pen_yaw]))
    T = pad_down(0.002, -0.003, 2 * r - 0.3e-3, yaw_deg=pad_yaw)
    force, _ = sensor.force_image(T, [pen, Table(height=0.0)])
    f = extract(force, method="moments")
    assert f.in_contact and f.area < 100  # a line, not a patch
    axis_world = Rotation.from_euler("z", pen_yaw, degrees=True).apply([1.0, 0.0, 0.0])
    axis_s = T[:3, :3].T @ axis_world
    expected = wrap_half_pi(np.arctan2(axis_s[1], axis_s[0]))
    assert abs(wrap_half_pi(f.orientation - expected)) < np.deg2rad(2.0)


def _area_at_pressure(sensor, obj, top_z, target=defaults.TARGET_PRESSURE_PA, deepest=0.06):
    """Press the pad down onto ``obj`` until the extracted pressure reaches ``target``."""
    lo, hi = 0.0, deepest
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        f = extract(sensor.force_image(pad_down(0.0, 0.0, top_z - mid), [obj])[0])
        if f.in_contact and f.pressure >= target:
            hi = mid
        else:
            lo = mid
    f = extract(sensor.force_image(pad_down(0.0, 0.0, top_z - hi), [obj])[0])
    return f, hi


def test_a_soft_ball_shows_a_much_larger_contact_area_than_a_rigid_pen():
    sensor = quiet_model()
    ball = Sphere(radius=0.06, stiffness=1e2, pose=object_pose([0.0, 0.0, 0.06]))
    pen = Cylinder(radius=0.004, length=0.14, stiffness=1e7, pose=object_pose([0.0, 0.0, 0.004], [0, 0, 30]))
    soft, soft_depth = _area_at_pressure(sensor, ball, 0.12)
    rigid, rigid_depth = _area_at_pressure(sensor, pen, 0.008, deepest=0.004)
    assert soft.pressure == pytest.approx(2000, rel=0.05) and rigid.pressure == pytest.approx(2000, rel=0.05)
    assert soft.area >= 3 * rigid.area
    assert soft_depth > 20 * rigid_depth  # the ball gives way, the pen hardly
    # and the soft contact grows with the force
    half, _ = _area_at_pressure(sensor, ball, 0.12, target=1000)
    assert half.area < soft.area


# --------------------------------------------------------------------------------- scenes

FORCE_TREE = "root: {sequence: {children: [{approach: {}}, {force_hold: {}}]}}"


@pytest.mark.parametrize("name", NEW_SCENES)
def test_scene_loads_starts_above_the_object_and_reaches_contact(name):
    scene = load_scene(SIM / f"{name}.yaml")
    assert scene.name == name and scene.mount.type == "lwr4"  # the paper's arm
    assert scene.mount_pose[2, 2] == pytest.approx(-1.0)  # the pad's normal points down
    world = scene.build_world(np.random.default_rng(0))
    world.sense()
    assert world.last_penetration == 0.0
    # the nearest object is a few mm below the pad's centre
    gap = min(float(o.sdf(scene.mount_pose[None, :3, 3])[0]) for o in scene.objects)
    assert 1e-3 < gap < 6e-3
    tree = load_tree(f"{name}-force", text=FORCE_TREE)
    result = run_mission(tree, scene, duration=3.0, seed=0)  # the soft ball needs ~2 s to reach
    log = result.log
    assert result.report["status"] in ("completed", "success"), result.report
    touching = log["in_contact"] == 1.0
    assert touching.any() and np.nanmax(log["force_n"]) > 0.5
    for key in ("force_n", "penetration_m", "position_m", "twist_s", "rotation"):
        assert np.all(np.isfinite(log[key])), key
    assert np.all(np.isfinite(log["pressure_pa"][touching]))
    assert np.nanmax(log["penetration_m"]) < 0.05


def test_pen_scene_stiffness_override_changes_the_pen():
    scene = load_scene(SIM / "pen.yaml", ["objects.0.stiffness=1e2"])
    assert isinstance(scene.objects[0], Cylinder) and scene.objects[0].stiffness == 1e2


# --------------------------------------------------------------------------------- schema errors

BOX_SCENE = """\
name: test
objects:
  - type: box
    size: [0.1, 0.1, 0.05]
    position: [0.0, 0.0, 0.025]
    rpy_deg: [0, 0, 30]
    stiffness: 1e5
  - type: mesh
    path: meshes/thing.stl
"""


def _error(tmp_path, text, overrides=None):
    path = write(tmp_path, text)
    with pytest.raises(SceneError) as info:
        load_scene(path, overrides)
    return path, str(info.value)


def test_new_objects_load_with_their_pose(tmp_path):
    import trimesh

    (tmp_path / "meshes").mkdir()
    trimesh.creation.box(extents=(0.02, 0.03, 0.04)).export(tmp_path / "meshes" / "thing.stl")
    scene = load_scene(write(tmp_path, BOX_SCENE + "    scale: 2.0\n    resolution: 0.002\n"))
    box, mesh = scene.objects
    assert isinstance(box, Box) and box.size == (0.1, 0.1, 0.05) and box.stiffness == 1e5
    assert_allclose(box.pose, object_pose([0.0, 0.0, 0.025], [0, 0, 30]))
    assert_allclose(mesh.bounds(), [[-0.02, -0.03, -0.04], [0.02, 0.03, 0.04]], atol=1e-12)
    assert_allclose(mesh.sdf(np.array([[0.0, 0.0, 0.0], [0.025, 0.0, 0.0], [0.0, 0.0, -0.043]])),
                    [-0.02, 0.005, 0.003], atol=1e-8)  # STL stores float32


@pytest.mark.parametrize(
    "old,new,line,fragments",
    [
        ("    size: [0.1, 0.1, 0.05]", "    size: [0.1, -0.1, 0.05]", 4, ["objects.0.size[1]", "positive"]),
        ("    size: [0.1, 0.1, 0.05]", "    size: [0.1, 0.1]", 4, ["objects.0.size", "list of 3"]),
        ("    size: [0.1, 0.1, 0.05]", "    sise: [0.1, 0.1, 0.05]", 4, ["sise", "did you mean 'size'"]),
        ("    rpy_deg: [0, 0, 30]", "    rpy_deg: [0, 0, thirty]", 6, ["objects.0.rpy_deg[2]", "number"]),
        ("    position: [0.0, 0.0, 0.025]", "    position: 0.025", 5, ["objects.0.position", "list of 3"]),
        ("    stiffness: 1e5", "    stiffness: -1e5", 7, ["objects.0.stiffness", "positive"]),
        ("  - type: box", "  - type: boxx", 3, ["unknown object type 'boxx'", "did you mean 'box'"]),
        ("    size: [0.1, 0.1, 0.05]\n", "", 3, ["objects.0.size", "a box needs 'size'"]),
        ("    path: meshes/thing.stl", "    path: meshes/thing.stl", 9, ["objects.1.path", "not found", "thing.stl"]),
        ("    path: meshes/thing.stl", "    path: [meshes/thing.stl]", 9, ["objects.1.path", "string"]),
    ],
)
def test_object_errors_name_file_line_and_field(tmp_path, old, new, line, fragments):
    assert old in BOX_SCENE
    path, msg = _error(tmp_path, BOX_SCENE.replace(old, new))
    assert msg.startswith(f"{path}:{line}:"), msg
    for fragment in fragments:
        assert fragment in msg, msg


def test_a_broken_mesh_file_is_an_error_at_its_path(tmp_path):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "thing.stl").write_text("solid nothing\nendsolid nothing\n")
    path, msg = _error(tmp_path, BOX_SCENE)
    assert msg.startswith(f"{path}:9:") and "objects.1.path" in msg


def test_an_open_mesh_is_an_error(tmp_path):
    import trimesh

    (tmp_path / "meshes").mkdir()
    ball = trimesh.creation.icosphere(subdivisions=2, radius=0.02)
    keep = ~np.any(ball.faces == 0, axis=1)  # a five-sided hole around vertex 0
    trimesh.Trimesh(ball.vertices, ball.faces[keep]).export(tmp_path / "meshes" / "thing.stl")
    path, msg = _error(tmp_path, BOX_SCENE)
    assert msg.startswith(f"{path}:9:") and "watertight" in msg


@pytest.mark.parametrize(
    "override,fragments",
    [
        ("objects.0.size=[0.1, 0.0, 0.1]", ["objects.0.size[1]", "positive"]),
        ("objects.0.radius=0.1", ["objects.0.radius", "unknown field"]),
        ("objects.0.position=[0, 0]", ["objects.0.position", "list of 3"]),
        ("objects.1.path=nowhere.ply", ["objects.1.path", "not found", "nowhere.ply"]),
        ("objects.1.scale=0", ["objects.1.scale", "positive"]),
    ],
)
def test_overrides_of_the_new_fields_are_validated(tmp_path, override, fragments):
    import trimesh

    (tmp_path / "meshes").mkdir()
    trimesh.creation.box(extents=(0.02, 0.03, 0.04)).export(tmp_path / "meshes" / "thing.stl")
    _, msg = _error(tmp_path, BOX_SCENE, [override])
    assert msg.startswith("--set " + override.split("=")[0]), msg
    for fragment in fragments:
        assert fragment in msg, msg


def test_override_of_a_shipped_scene_goes_through_the_checks():
    with pytest.raises(SceneError, match=r"objects\.0\.radius.*positive"):
        load_scene(SIM / "soft_ball.yaml", ["objects.0.radius=-0.06"])
    scene = load_scene(SIM / "soft_ball.yaml", ["objects.0.radius=0.05", "objects.0.position=[0, 0, 0.05]"])
    assert scene.objects[0].radius == 0.05
    assert_allclose(scene.objects[0].pose[:3, 3], [0.0, 0.0, 0.05])


def test_sim_objects_are_sim_objects():
    for obj in _posed_primitives():
        assert isinstance(obj, SimObject)
