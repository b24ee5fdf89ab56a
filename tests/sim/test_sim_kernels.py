"""The compiled simulator kernels give the answers of the implementations they replaced.

Oracles: the Python solvers of the arm (still used for other contact models and for the steps the
kernels hand back), the objects' numpy ``sdf``/``depth``, and the numpy pad model in
``tests/oracles_sim.py``.  Random inputs come from hypothesis.

Tolerances (stated once here): poses and positions 1e-9 m, joint angles 1e-9 rad, joint
velocities 1e-9 rad/s (relative to the largest when that exceeds 1), forces and wrenches 1e-9
relative to the largest, signed distances and depths 1e-12 m, raw counts identical (one count
where the noise-free value lies within rounding of a half count).
"""

from __future__ import annotations


import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from oracles_sim import OracleSensorModel, python_contact
from tactile_bt.control.spatial import body_to_spatial, make_pose
from tactile_bt.robot import kernels as rk
from tactile_bt.robot.kinematics import Q_MAX, Q_MIN, Q_READY, LWR4Kinematics
from tactile_bt.robot.redundancy import LimitAvoidance
from tactile_bt.robot.stepping import CompiledContact
from tactile_bt.robot.resolved_rate import damped_least_squares
from tactile_bt.sim import kernels as sk
from tactile_bt.sim.objects import Cable, Table, object_pose, polyline_from_segments
from tactile_bt.sim.pad import SensorModel
from tactile_bt.sim.scene import load_scene
from tactile_bt.sim.shapes import Box, Cylinder, Sphere

from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
FINITE = dict(allow_nan=False, allow_infinity=False)


def unit(x, lo, hi):
    return lo + (hi - lo) * x


fractions = st.lists(st.floats(0.0, 1.0, **FINITE), min_size=7, max_size=7).map(np.array)
seeds = st.integers(0, 2**31 - 1)


def posture(fr: np.ndarray) -> np.ndarray:
    """A posture inside the limits, 5 degrees clear of them."""
    margin = np.radians(5.0)
    return Q_MIN + margin + fr * (Q_MAX - Q_MIN - 2 * margin)


def random_pose(rng: np.random.Generator, scale: float = 0.3) -> np.ndarray:
    return make_pose(Rotation.random(random_state=rng), rng.uniform(-scale, scale, 3))


# ------------------------------------------------------------------------------- the arm
@SETTINGS
@given(fractions, seeds)
def test_pose_and_jacobian_match_the_python_chain(fr, seed):
    rng = np.random.default_rng(seed)
    kin = LWR4Kinematics(mount=random_pose(rng, 0.05), base=random_pose(rng))
    q = posture(fr)
    T, J = np.empty((4, 4)), np.empty((6, 7))
    rk.pose_jacobian(q, kin.packed, T, J)
    T0, J0 = kin.pose_and_jacobian(q)
    assert_allclose(T, T0, rtol=0, atol=1e-12)
    assert_allclose(J, J0, rtol=0, atol=1e-12)


@SETTINGS
@given(seeds, st.integers(1, 7), st.floats(0.0, 0.1, **FINITE), st.floats(0.01, 0.3, **FINITE), st.booleans(),
       st.booleans())
def test_damped_least_squares_matches_the_lapack_solve(seed, n, lam, eps, null, rank_deficient):
    rng = np.random.default_rng(seed)
    A = rng.normal(scale=rng.uniform(0.05, 1.0), size=(6, n))
    if rank_deficient and n > 1:
        A[:, -1] = A[:, 0] * rng.uniform(-2, 2)
    rhs = rng.normal(size=6)
    z = rng.normal(size=n) if null else np.zeros(n)
    x = np.empty(n)
    lam_k, smin_k = rk.dls_solve(np.ascontiguousarray(A), rhs, lam, eps, z, null, 0.5, x)
    x0, lam0, smin0 = damped_least_squares(A, rhs, lam, eps, z if null else None, 0.5 if null else None)
    scale = max(1.0, float(np.max(np.abs(x0))))
    assert_allclose(x, x0, rtol=0, atol=1e-9 * scale)
    assert lam_k == pytest.approx(lam0, abs=1e-9)
    assert smin_k == pytest.approx(smin0, abs=1e-9)


@SETTINGS
@given(fractions)
def test_limit_avoidance_matches_the_python_objective(fr):
    kin = LWR4Kinematics()
    q = Q_MIN + fr * (Q_MAX - Q_MIN)
    avoid = LimitAvoidance()
    out = np.empty(7)
    rk.limit_avoidance(q, kin.packed, rk.pack_arm(np.ones(7), np.ones(7), avoid), out)
    assert_allclose(out, avoid.q_dot(q, kin.q_min, kin.q_max), rtol=1e-12, atol=1e-12)


@SETTINGS
@given(fractions, seeds, st.booleans())
def test_compiled_resolved_rates_match_the_python_solve_or_hand_it_back(fr, seed, redundant):
    rng = np.random.default_rng(seed)
    kin = LWR4Kinematics()
    q = posture(fr)
    V = np.concatenate((rng.normal(scale=0.05, size=3), rng.normal(scale=0.5, size=3)))
    avoid = LimitAvoidance() if redundant else None
    dt = 0.004
    out = np.zeros(rk.OUT_SIZE)
    done = rk.rates_fast(q, V, kin.packed, rk.pack_arm(np.ones(7), np.ones(7), avoid), dt, 0.05, 0.05, out)
    null = None if avoid is None else avoid.q_dot(q, kin.q_min, kin.q_max)
    sol = kin.resolved_rate(q, V, dt=dt, damping=0.05, sigma_threshold=0.05, q_dot_null=null,
                            null_speed_max=None if avoid is None else avoid.speed_max, return_info=True)
    if not done:  # handed back: near a singularity (the damping on), or a joint would pass its
        # limit within the step, so one lies within a step at its top speed of it (the
        # velocities are scaled within the top speeds)
        reach = dt * kin.qd_max * (1.0 + 1e-9)
        assert sol.damping > 0.0 or np.any((q - kin.q_min <= reach) | (kin.q_max - q <= reach))
        return
    assert sol.damping == 0.0
    assert not sol.saturated.any()
    scale = max(1.0, float(np.max(np.abs(sol.q_dot))))
    assert_allclose(out[rk.O_QD:rk.O_QD + 7], sol.q_dot, rtol=0, atol=1e-9 * scale)
    assert_allclose(out[rk.O_RRES:rk.O_RRES + 6], sol.residual, rtol=0, atol=1e-9 * scale)
    assert out[rk.O_LAM] == pytest.approx(sol.damping, abs=1e-9)
    assert out[rk.O_SMIN] == pytest.approx(sol.sigma_min, abs=1e-9)
    assert out[rk.O_SCALE] == pytest.approx(sol.scale, rel=1e-12)


def test_a_joint_driven_into_its_limit_is_handed_back_to_the_python_solve():
    kin = LWR4Kinematics()
    q = Q_READY.copy()
    q[0] = Q_MAX[0] - 1e-4
    V = kin.spatial_jacobian(q) @ np.array([1.0, 0, 0, 0, 0, 0, 0])  # turn joint 1 outwards
    out = np.zeros(rk.OUT_SIZE)
    assert not rk.rates_fast(q, V, kin.packed, rk.pack_arm(np.ones(7), np.ones(7), None), 0.004, 0.05, 0.05, out)
    assert kin.resolved_rate(q, V, dt=0.004, return_info=True).saturated[0]


def _worlds(scene_file: str, seed: int = 0):
    """Two worlds of a scene: the compiled one, and one whose arm uses the Python solvers."""
    scene = load_scene(ROOT / "sim" / scene_file)
    compiled = scene.build_world(np.random.default_rng(seed))
    oracle = scene.build_world(np.random.default_rng(seed))
    oracle.mount.arm.contact = python_contact(oracle)
    assert isinstance(compiled.mount.arm.contact, CompiledContact)  # the arm steps in the kernels
    assert not isinstance(oracle.mount.arm.contact, CompiledContact)
    return compiled, oracle


@pytest.mark.parametrize("scene_file, press", [("cable.yaml", 0.007), ("scan_ellipsoid.yaml", 0.006),
                                               ("pen.yaml", 0.006)])
def test_compiled_arm_steps_match_the_python_solvers(scene_file, press):
    """Press into the scene's object and slide with random twists: both arms stay together."""
    a, b = _worlds(scene_file)
    rng = np.random.default_rng(1)
    dt = 0.004
    steps = int(press / 0.01 / dt)  # down at 10 mm/s to `press` below the start
    twists = [np.array([0, 0, 0.01, 0, 0, 0])] * steps
    twists += [np.concatenate((rng.normal(scale=0.005, size=3) + [0, 0, 0.002], rng.normal(scale=0.05, size=3)))
               for _ in range(60)]
    pressed = 0.0
    for V in twists:
        for w in (a, b):
            w.move(body_to_spatial(w.pose, V), dt)
        arm_a, arm_b = a.mount.arm, b.mount.arm
        assert_allclose(arm_a.q, arm_b.q, rtol=0, atol=1e-9)
        assert_allclose(arm_a.q_eq, arm_b.q_eq, rtol=0, atol=1e-9)
        assert_allclose(arm_a.pose, arm_b.pose, rtol=0, atol=1e-9)
        scale = max(1.0, float(np.max(np.abs(arm_b.wrench_g))))
        assert_allclose(arm_a.wrench_g, arm_b.wrench_g, rtol=0, atol=1e-6 * scale)
        pressed = max(pressed, float(np.linalg.norm(arm_a.wrench_g[:3])))
    assert pressed > 0.1  # the pad did press on the object


def test_a_step_that_needs_the_line_search_is_finished_by_the_python_solver():
    """A deep push into a stiff table needs the bracketing line search: the kernel hands the step
    back and the Python solver finishes it; the result is the Python solver's."""
    a, b = _worlds("cable.yaml")
    for w in (a, b):
        w.objects[:] = [Table(height=float(w.pose[2, 3]) - 0.0005, stiffness=1e7)]
        w.sensor.invalidate()
    V = np.array([0, 0, 0.2, 0, 0, 0])  # 0.8 mm per step into 1e7 N/m
    for _ in range(5):
        for w in (a, b):
            w.move(body_to_spatial(w.pose, V), 0.004)
        assert_allclose(a.mount.arm.q, b.mount.arm.q, rtol=0, atol=1e-9)
    assert a.mount.arm.last_solve.converged


# ------------------------------------------------------------------------------- shapes
def _shapes(rng: np.random.Generator):
    path = polyline_from_segments((-0.05, 0.0), 10.0, [{"straight": 0.03}, {"arc": {"radius": 0.03, "angle_deg": 60}}])
    return [
        Table(height=rng.uniform(-0.01, 0.01), pose=object_pose(rng.uniform(-0.01, 0.01, 3), (0, 0, 30))),
        Cable(path=path, radius=0.003, pose=object_pose((0.01, -0.02, 0.0), (0, 0, rng.uniform(-90, 90)))),
        Cable(path=path, radius=0.003),
        Box(size=(0.04, 0.03, 0.02), pose=object_pose(rng.uniform(-0.01, 0.01, 3), rng.uniform(-180, 180, 3))),
        Sphere(radius=0.02, pose=object_pose(rng.uniform(-0.01, 0.01, 3))),
        Cylinder(radius=0.008, length=0.05, pose=object_pose(rng.uniform(-0.01, 0.01, 3), rng.uniform(-180, 180, 3))),
    ]


@pytest.fixture(scope="module")
def mesh_shape():
    import trimesh

    from tactile_bt.sim.mesh_object import MeshObject

    ico = trimesh.creation.icosphere(subdivisions=2, radius=0.02)
    return MeshObject.from_arrays(ico.vertices, ico.faces, resolution=2e-3, pose=object_pose((0.003, 0, 0), (10, 20, 30)))


def _kernel_sdf_depth(obj, points, normal):
    objf, grids = sk.pack_objects([obj], 2e7, 25e-6, 9)
    n = len(points)
    P = np.ascontiguousarray(points, dtype=float)
    L = np.empty_like(P)
    sk.to_local(objf, 0, P, n, L)
    sdf, depth = np.empty(n), np.empty(n)
    sk.local_sdf(objf, grids, 0, L, n, sdf)
    nl = obj.pose[:3, :3].T @ normal
    sk.local_depth(objf, grids, 0, L, n, float(nl[0]), float(nl[1]), float(nl[2]), depth)
    return sdf, depth


@SETTINGS
@given(seed=seeds)
def test_every_shape_s_distance_and_depth_match_its_numpy_version(mesh_shape, seed):
    rng = np.random.default_rng(seed)
    normal = Rotation.random(random_state=rng).apply([0, 0, 1.0])
    if rng.random() < 0.5:
        normal = np.array([0, 0, -1.0])  # pressing from above, as the pad mostly does
    points = rng.uniform(-0.06, 0.06, (400, 3))
    points[:200] *= 0.3  # many points inside or near the shapes
    for obj in _shapes(rng) + [mesh_shape]:
        sdf, depth = _kernel_sdf_depth(obj, points, normal)
        assert_allclose(sdf, obj.sdf(points), rtol=0, atol=1e-12, err_msg=type(obj).__name__)
        assert_allclose(depth, obj.depth(points, normal), rtol=0, atol=1e-12, err_msg=type(obj).__name__)


def test_grid_interpolation_outside_the_grid_reads_its_border_like_scipy():
    """Cable and mesh grids: points beyond every face and corner of the grid."""
    path = polyline_from_segments((0.0, 0.0), 0.0, [{"straight": 0.02}])
    cable = Cable(path=path, radius=0.002)
    far = np.array([[x, y, 0.001] for x in (-0.1, -0.011, 0.0, 0.031, 0.2) for y in (-0.1, -0.013, 0.0, 0.013, 0.1)])
    sdf, depth = _kernel_sdf_depth(cable, far, np.array([0, 0, -1.0]))
    assert_allclose(sdf, cable.sdf(far), rtol=0, atol=1e-12)
    assert_allclose(depth, cable.depth(far, np.array([0, 0, -1.0])), rtol=0, atol=1e-12)


# ------------------------------------------------------------------------------- the pad
SCENE_OBJECTS = ["cable.yaml", "pen.yaml", "toy_box.yaml", "roll_ball.yaml", "scan_ellipsoid.yaml", "edge.yaml"]


@pytest.mark.parametrize("scene_file", SCENE_OBJECTS)
def test_pad_model_matches_the_numpy_pad_model(scene_file):
    """Force image, contact wrench and stiffness, and raw frames, at random poses around each
    scene's start (the same poses in the same order: the same broad phases)."""
    scene = load_scene(ROOT / "sim" / scene_file)
    params = scene.sensor
    new, old = SensorModel(params, np.random.default_rng(3)), OracleSensorModel(params, np.random.default_rng(3))
    objects = list(scene.objects)
    rng = np.random.default_rng(4)
    start = scene.mount_pose
    touched = 0
    for k in range(40):
        T = start.copy()
        T[:3, :3] = Rotation.from_rotvec(rng.normal(scale=0.15, size=3)).as_matrix() @ start[:3, :3]
        T[:3, 3] += rng.normal(scale=0.004, size=3) + T[:3, 2] * rng.uniform(0.0, 0.008)  # pressed in
        if k % 3 == 0:
            T[:3, 3] += rng.normal(scale=5e-4, size=3)  # small moves: the broad phase is kept
        f_new, d_new = new.force_image(T, objects)
        f_old, d_old = old.force_image(T, objects)
        scale = max(1e-12, float(f_old.max()))
        assert_allclose(f_new, f_old, rtol=0, atol=1e-9 * scale)
        assert d_new == pytest.approx(d_old, abs=1e-12)
        w_new, K_new = new.contact(T, objects)
        w_old, K_old = old.contact(T, objects)
        assert_allclose(w_new, w_old, rtol=0, atol=1e-9 * max(1.0, float(np.abs(w_old).max())))
        assert_allclose(K_new, K_old, rtol=0, atol=1e-9 * max(1.0, float(np.abs(K_old).max())))
        r_new, r_old = new.raw_frame(f_new), old.raw_frame(f_old)
        assert np.abs(r_new.astype(int) - r_old).max() <= 1
        touched += d_old > 0
    assert touched > 5


def test_sense_is_force_image_then_raw_frame_with_the_same_draws():
    scene = load_scene(ROOT / "sim" / "cable.yaml")
    a, b = SensorModel(scene.sensor, np.random.default_rng(5)), OracleSensorModel(scene.sensor, np.random.default_rng(5))
    T = scene.mount_pose.copy()
    T[2, 3] -= 0.0065  # 1.5 mm into the cable
    for _ in range(5):
        raw, force, deepest = a.sense(T, scene.objects)
        f_old, d_old = b.force_image(T, scene.objects)
        assert_allclose(force, f_old, rtol=0, atol=1e-9 * max(1e-12, float(f_old.max())))
        assert np.array_equal(raw, b.raw_frame(f_old))
        assert deepest == pytest.approx(d_old, abs=1e-12)
    assert deepest > 0


def test_the_pad_and_arm_kernels_are_compiled_once_for_every_scene():
    """One machine-code version of each of the pad's kernels and of the arm's step serves every
    shape and use."""
    for name in ("cable.yaml", "scan_ellipsoid.yaml", "toy_box.yaml"):
        world = load_scene(ROOT / "sim" / name).build_world(np.random.default_rng(0))
        world.sense()
        world.move(np.zeros(6), 0.004)
    assert len(sk.pad_contact.signatures) == len(sk.foam_spread.signatures) == len(sk.raw_counts.signatures) == 1
    assert len(rk.arm_step.signatures) == len(rk.rates_fast.signatures) == 1
