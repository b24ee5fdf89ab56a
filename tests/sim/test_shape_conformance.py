"""Every registered object shape keeps the contract of :class:`tactile_bt.sim.registry.Shape`:
it loads from its example in a scene file, its schema rejects bad values with file, line and
field, its compiled form agrees with its numpy signed distance and depth, its signed distance
agrees with its surface mesh, that mesh is closed, and it draws in ``tactile-bt view``.

The shapes are those registered when the tests are collected: a new shape module is checked
here without editing this file.
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from test_sim_kernels import _kernel_sdf_depth as kernel_sdf_depth
from tactile_bt.errors import SceneError
from tactile_bt.sim import registry
from tactile_bt.sim.objects import SimObject
from tactile_bt.sim.registry import register_shape, shape_class, shape_names
from tactile_bt.sim.scene import load_scene
from tactile_bt.sim.schema import LENGTH

REPO = Path(__file__).resolve().parents[2]
SHAPES = shape_names()
#: Shapes that are never scanned, so have no surface mesh: the table (the set-up) and cables (followed).
NOT_SCAN_TARGETS = {"table", "cable"}
#: Where the example objects stand: off the origin and turned, so that poses are exercised.
POSITION, RPY_DEG = [0.004, -0.006, 0.003], [10, 20, 30]
#: The kernels' grid path (meshes, shapes without a compiled form) interpolates a 1 mm grid:
#: within this of the exact signed distance near a curved surface.
GRID_TOLERANCE_M = 2e-5
#: ... and within this of it within a cell of a sharp crease (tactile_bt.sim.mesh_object).
GRID_CREASE_ERROR_M = 3e-4
#: ... and within a cell of an acute wedge (the 40° edge where a pyramid's face meets its base),
#: which a 1 mm grid rounds off by up to most of a cell.
GRID_WEDGE_ERROR_M = 1e-3


def scene_text(kind: str, fields: dict) -> str:
    """A scene with one object of ``kind``: one key per line, the object's own keys from line 7."""
    lines = ["mount: {type: cartesian, position: [0.0, 0.0, 2.0]}", "objects:", f"  - type: {kind}",
             f"    position: {POSITION}", f"    rpy_deg: {RPY_DEG}", "    stiffness: 1.0e5"]
    lines += [f"    {key}: {value!r}" if isinstance(value, str) else f"    {key}: {value}"
              for key, value in fields.items()]
    return "\n".join(lines).replace("'", '"') + "\n"


def write_scene(tmp_path: Path, kind: str, fields: dict) -> Path:
    """The scene file, next to a link to the shipped meshes (examples name files as the shipped
    scenes in sim/ do)."""
    meshes = tmp_path / "meshes"
    if not meshes.exists():
        meshes.symlink_to(REPO / "sim" / "meshes")
    path = tmp_path / f"{kind}.yaml"
    path.write_text(scene_text(kind, fields))
    return path


@pytest.fixture(scope="module")
def examples(tmp_path_factory):
    """Every registered shape, loaded from its example (built once per module)."""
    tmp = tmp_path_factory.mktemp("shapes")
    return {kind: load_scene(write_scene(tmp, kind, dict(shape_class(kind).example))).objects[0] for kind in SHAPES}


def near_crease(obj: SimObject, points: np.ndarray, reach: float = 1.5e-3) -> np.ndarray:
    """Points within about a grid cell of a sharp crease of ``obj`` (a ridge, a rim): over the
    cube of ±``reach`` around them, the signed distance departs from a plane by more than
    2e-5 m (a smooth surface of 10 mm radius or more by less than a third of a millimetre)."""
    offsets = reach * np.array([[i, j, k] for i in (-1, 0, 1) for j in (-1, 0, 1) for k in (-1, 0, 1)], float)
    values = np.stack([obj.sdf(points + o) for o in offsets], axis=1)          # (N, 27)
    design = np.column_stack((np.ones(len(offsets)), offsets))                  # (27, 4)
    fit = values @ np.linalg.pinv(design).T @ design.T                          # the best plane
    return np.max(np.abs(values - fit), axis=1) > GRID_TOLERANCE_M


def probe_points(obj: SimObject, rng: np.random.Generator, n: int = 3000) -> np.ndarray:
    """World points in and around ``obj`` (within 10 cm of its frame for unbounded objects)."""
    lo, hi = obj.local_bounds()
    lo, hi = np.maximum(lo, -0.1) - 0.01, np.minimum(hi, 0.1) + 0.01
    local = rng.uniform(lo, hi, (n, 3))
    return local @ obj.pose[:3, :3].T + obj.pose[:3, 3]


@pytest.mark.parametrize("kind", SHAPES)
def test_a_shape_loads_from_its_example_at_the_scene_pose(examples, kind):
    obj = examples[kind]
    assert type(obj) is shape_class(kind) and obj.type_name == kind
    assert obj.stiffness == 1e5
    assert_allclose(obj.pose[:3, 3], POSITION)
    assert set(obj.required) <= set(obj.schema) and set(obj.example) <= set(obj.schema)


@pytest.mark.parametrize("kind", SHAPES)
def test_the_schema_rejects_bad_values_with_file_line_and_field(tmp_path, kind):
    example = dict(shape_class(kind).example)
    for key in shape_class(kind).schema:
        fields = {**example, key: "{bad: 1}"}  # a mapping is no kind of shape value
        fields = {key: fields.pop(key), **fields}  # the bad key on line 7
        path = write_scene(tmp_path, kind, fields)
        path.write_text(path.read_text().replace('"{bad: 1}"', "{bad: 1}"))
        with pytest.raises(SceneError) as info:
            load_scene(path)
        assert str(info.value).startswith(f"{path}:7:") and f"objects.0.{key}" in str(info.value), str(info.value)
    for key in shape_class(kind).required:
        path = write_scene(tmp_path, kind, {k: v for k, v in example.items() if k != key})
        with pytest.raises(SceneError, match=rf"^{path}:3:.*objects\.0\.{key}: a {kind} needs '{key}'"):
            load_scene(path)


@pytest.mark.parametrize("kind", SHAPES)
def test_the_compiled_form_agrees_with_the_numpy_signed_distance_and_depth(examples, kind):
    obj = examples[kind]
    rng = np.random.default_rng(1)
    points = probe_points(obj, rng)
    exact = obj.sdf(points)
    crease = near_crease(obj, points)
    for normal in (np.array([0.0, 0.0, -1.0]), np.array([0.6, 0.0, -0.8])):
        sdf, depth = kernel_sdf_depth(obj, points, normal)
        near = np.abs(exact) < 3e-3  # where the pad touches; farther only the broad phase reads it
        assert near.sum() > 100
        # within a grid cell of a sharp crease (a ridge, a rim) the grid blurs the crease
        tolerance = np.where(crease[near], GRID_WEDGE_ERROR_M, GRID_TOLERANCE_M)
        assert np.all(np.abs(sdf[near] - exact[near]) <= tolerance)
        assert np.all(np.abs(depth[near] - obj.depth(points[near], normal)) <= tolerance)
        # farther outside, never above the true distance: the broad phase keeps every tactel that
        # can touch
        outside = exact > 0
        assert np.all(sdf[outside] <= exact[outside] + np.where(crease[outside], GRID_WEDGE_ERROR_M, GRID_TOLERANCE_M))


@pytest.mark.parametrize("kind", SHAPES)
def test_the_signed_distance_agrees_with_the_surface_mesh(examples, kind):
    obj = examples[kind]
    mesh = obj.surface_mesh()
    if mesh is None:  # no scan target: nothing to agree with
        assert kind in NOT_SCAN_TARGETS, f"a {kind} has no surface mesh"
        return
    import trimesh

    c, face = trimesh.sample.sample_surface(mesh, 2000, seed=2)  # evenly over the area
    n = np.asarray(mesh.face_normals)[face]
    world = lambda p: p @ obj.pose[:3, :3].T + obj.pose[:3, 3]  # noqa: E731
    # on the mesh: within a mesh grid's error (0.1-0.3 mm within a cell of a sharp crease)
    assert np.max(np.abs(obj.sdf(world(c)))) < GRID_CREASE_ERROR_M
    # half a millimetre off it along the face normal: outside; inside, but for a few points in a
    # thin wedge at a sharp rim, where a grid of 1 mm cells blurs the crease
    assert np.all(obj.sdf(world(c + 5e-4 * n)) > 1e-4)
    # (an acute wedge is thinner than that step near its edge: points within 2 mm of an edge
    # where the faces' normals turn by more than 90°, such as a pyramid's base edge, are left out)
    inside = obj.sdf(world(c - 5e-4 * n))
    acute = np.asarray(mesh.face_adjacency_edges)[np.asarray(mesh.face_adjacency_angles) > np.pi / 2]
    if len(acute):
        u, v = np.asarray(mesh.vertices)[acute[:, 0]], np.asarray(mesh.vertices)[acute[:, 1]]
        t = np.clip(np.einsum("mek,ek->me", c[:, None] - u[None], v - u) / np.einsum("ek,ek->e", v - u, v - u), 0, 1)
        gap = np.linalg.norm(c[:, None] - (u[None] + t[..., None] * (v - u)[None]), axis=2).min(axis=1)
        inside = inside[gap > 2e-3]
    assert np.all(inside < GRID_CREASE_ERROR_M) and np.mean(inside < -1e-4) > 0.95


@pytest.mark.parametrize("kind", SHAPES)
def test_the_surface_mesh_is_closed_and_inside_the_bounds(examples, kind):
    obj = examples[kind]
    mesh = obj.surface_mesh()
    if mesh is None:
        assert kind in NOT_SCAN_TARGETS, f"a {kind} has no surface mesh"
        return
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0
    lo, hi = obj.local_bounds()
    assert np.all(mesh.bounds[0] >= lo - 1e-9) and np.all(mesh.bounds[1] <= hi + 1e-9)


@pytest.mark.parametrize("kind", SHAPES)
def test_the_shape_draws_in_the_view_where_it_is(examples, kind):
    pv = pytest.importorskip("pyvista")
    from tactile_bt.mission.view import _scene_meshes

    obj = examples[kind]
    extent = np.array([[-0.2, -0.2, -0.1], [0.2, 0.2, 0.2]])
    scene = type("SceneStub", (), {"objects": [obj]})()
    drawn = _scene_meshes(scene, pv, extent)
    assert len(drawn) == 1, f"a {kind} draws nothing"
    mesh = drawn[0][1]
    assert mesh.n_points > 0
    lo, hi = obj.bounds()  # infinite where the object is unbounded (a table)
    drawn_lo, drawn_hi = np.array(mesh.bounds).reshape(3, 2).T  # (xmin, xmax, ...) -> min, max
    assert np.all(drawn_lo >= lo - 1e-3) and np.all(drawn_hi <= hi + 1e-3)


# ------------------------------------------------------------------------------ the registry


@dataclass(eq=False)
class _Bead(SimObject):
    """A shape known only by its numpy signed distance: a bead of ``radius`` (m)."""

    schema = {"radius": LENGTH}
    required = ("radius",)
    example = {"radius": 0.02}
    radius: float = 0.02

    def local_bounds(self) -> np.ndarray:
        return np.array([[-self.radius] * 3, [self.radius] * 3])

    def local_sdf(self, points: np.ndarray) -> np.ndarray:
        return np.linalg.norm(points, axis=1) - self.radius


@pytest.fixture
def plugin_registry(monkeypatch):
    """A copy of the registry for the test to register into."""
    monkeypatch.setattr(registry, "_SHAPES", registry.registered_shapes())


def test_a_plugin_shape_loads_and_touches_the_pad_without_a_kernel_of_its_own(plugin_registry, tmp_path):
    from tactile_bt.sim.shapes import Sphere

    register_shape("bead")(_Bead)
    path = write_scene(tmp_path, "bead", {"radius": 0.02})
    bead = load_scene(path).objects[0]
    assert isinstance(bead, _Bead) and "bead" in shape_names()
    ball = Sphere(radius=0.02, pose=bead.pose)
    points = probe_points(bead, np.random.default_rng(3))
    normal = np.array([0.0, 0.0, -1.0])
    sdf, depth = kernel_sdf_depth(bead, points, normal)
    near = np.abs(ball.sdf(points)) < 3e-3
    assert_allclose(sdf[near], ball.sdf(points)[near], rtol=0, atol=GRID_TOLERANCE_M)
    assert_allclose(depth[near], np.maximum(-ball.sdf(points[near]), 0.0), rtol=0, atol=GRID_TOLERANCE_M)


def test_a_type_name_is_registered_once(plugin_registry):
    with pytest.raises(ValueError, match="already registered"):
        register_shape("box")(_Bead)
