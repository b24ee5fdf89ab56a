"""Tests of the KUKA LWR 4 model: kinematics, resolved rate, compliance and the equilibrium solver."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.spatial.transform import Rotation

from tactile_bt.control.spatial import adjoint, integrate_spatial, invert, make_pose, skew
from tactile_bt.robot.arm import CompliantArm, bracket_stiffness, point_wrench
from tactile_bt.robot.kinematics import (
    DEFAULT_MOUNT_OFFSET_M,
    Q_MAX,
    Q_MIN,
    Q_READY,
    LWR4Kinematics,
    default_mount,
)

D1, D3, D5, D7 = 0.3105, 0.4, 0.39, 0.078
MOUNT = DEFAULT_MOUNT_OFFSET_M
DEG = np.pi / 180.0


@pytest.fixture(scope="module")
def kin() -> LWR4Kinematics:
    return LWR4Kinematics()


def random_postures(n: int, seed: int, spread: float = 0.6) -> np.ndarray:
    """Seeded postures around the ready posture, inside the limits."""
    rng = np.random.default_rng(seed)
    q = Q_READY + rng.uniform(-spread, spread, size=(n, 7))
    return np.clip(q, Q_MIN + 0.1, Q_MAX - 0.1)


def Ry(deg: float) -> np.ndarray:
    return Rotation.from_euler("y", deg, degrees=True).as_matrix()


# ---------------------------------------------------------------------------- forward kinematics
def test_fk_stretched_arm_points_straight_up(kin):
    T = kin.fk(np.zeros(7))
    assert_allclose(T[:3, :3], np.eye(3), atol=1e-12)
    assert_allclose(T[:3, 3], [0.0, 0.0, D1 + D3 + D5 + D7 + MOUNT], atol=1e-12)
    heights = [0, D1, D1, D1 + D3, D1 + D3, D1 + D3 + D5, D1 + D3 + D5, D1 + D3 + D5 + D7,
               D1 + D3 + D5 + D7 + MOUNT]
    frames = kin.fk_all(np.zeros(7))
    assert frames.shape == (9, 4, 4)
    assert_allclose(frames[:, :3, 3], np.column_stack((np.zeros(9), np.zeros(9), heights)), atol=1e-12)
    assert_allclose(frames[8], T)
    assert_allclose(kin.fk_flange(np.zeros(7)) @ default_mount(), T)


@pytest.mark.parametrize(
    "joint, position, rotation",
    [
        # joint 1 turns about the vertical: the stretched arm only spins.
        (0, [0.0, 0.0, D1 + D3 + D5 + D7 + MOUNT], Rotation.from_euler("z", 90, degrees=True).as_matrix()),
        # joint 2 turns about -y at the shoulder: the arm falls over towards -x.
        (1, [-(D3 + D5 + D7 + MOUNT), 0.0, D1], Ry(-90)),
        # joint 4 turns about +y at the elbow: the forearm points along +x.
        (3, [D5 + D7 + MOUNT, 0.0, D1 + D3], Ry(90)),
        # joint 6 turns about -y at the wrist: the hand points along -x.
        (5, [-(D7 + MOUNT), 0.0, D1 + D3 + D5], Ry(-90)),
        # joint 7 turns the pad about its own normal.
        (6, [0.0, 0.0, D1 + D3 + D5 + D7 + MOUNT], Rotation.from_euler("z", 90, degrees=True).as_matrix()),
    ],
)
def test_fk_single_joint_at_90_degrees(kin, joint, position, rotation):
    q = np.zeros(7)
    q[joint] = np.pi / 2
    T = kin.fk(q)
    assert_allclose(T[:3, 3], position, atol=1e-12)
    assert_allclose(T[:3, :3], rotation, atol=1e-12)


def test_ready_posture_points_the_pad_down_in_front(kin):
    T = kin.fk(Q_READY)
    assert_allclose(T[:3, 2], [0.0, 0.0, -1.0], atol=1e-12)
    assert T[0, 3] > 0.4 and 0.2 < T[2, 3] < 0.5
    frames = kin.fk_all(Q_READY)
    assert frames[3, 2, 3] > frames[5, 2, 3]  # elbow above the wrist
    assert_allclose(kin.pad_down_pose(T[:3, 3]), T, atol=1e-12)


def test_default_mount_puts_the_pad_on_the_flange_axis():
    T_es = default_mount()
    assert_allclose(T_es[:3, :3], np.eye(3))
    assert_allclose(T_es[:3, 3], [0.0, 0.0, MOUNT])
    assert 0.01 <= MOUNT <= 0.1


def test_base_and_mount_transforms_compose(kin):
    base = make_pose(Rotation.from_euler("zyx", [0.3, -0.2, 0.1]), [0.1, -0.4, 0.75])
    mount = make_pose(Rotation.from_euler("z", 0.25 * np.pi), [0.0, 0.01, 0.05])
    moved = LWR4Kinematics(mount=mount, base=base)
    for q in random_postures(3, seed=1):
        assert_allclose(moved.fk(q), base @ kin.fk_flange(q) @ mount, atol=1e-12)
        J0 = LWR4Kinematics(mount=mount).spatial_jacobian(q)
        assert_allclose(moved.spatial_jacobian(q), adjoint(base) @ J0, atol=1e-12)


# ------------------------------------------------------------------------------- Jacobians
def _fd_spatial_twists(kin, q, h=1e-6):
    """Columns [v_g; w] from central differences of fk: [V_g] = dT/dq_j . T^-1."""
    T = kin.fk(q)
    cols, pdots = [], []
    for j in range(7):
        dq = np.zeros(7)
        dq[j] = h
        dT = (kin.fk(q + dq) - kin.fk(q - dq)) / (2 * h)
        X = dT @ invert(T)
        w = np.array([X[2, 1], X[0, 2], X[1, 0]])
        cols.append(np.concatenate((X[:3, 3], w)))
        pdots.append(dT[:3, 3])
    return np.array(cols).T, np.array(pdots).T


def test_spatial_jacobian_matches_finite_differences(kin):
    for q in random_postures(5, seed=2, spread=1.2):
        J = kin.spatial_jacobian(q)
        J_fd, p_dot = _fd_spatial_twists(kin, q)
        assert_allclose(J[3:], J_fd[3:], atol=1e-8)  # rotational rows
        assert_allclose(J[:3], J_fd[:3], atol=1e-8)  # translational rows
        # Spatial convention: v_g = p_dot + p x w.
        p = kin.fk(q)[:3, 3]
        assert_allclose(J[:3], p_dot + skew(p) @ J[3:], atol=1e-8)


def test_body_and_hybrid_jacobians(kin):
    for q in random_postures(3, seed=3):
        T = kin.fk(q)
        J = kin.spatial_jacobian(q)
        assert_allclose(kin.body_jacobian(q), adjoint(invert(T)) @ J, atol=1e-12)
        _, Jh = kin.hybrid_jacobian(q)
        _, p_dot = _fd_spatial_twists(kin, q)
        assert_allclose(Jh[:3], p_dot, atol=1e-8)
        assert_allclose(Jh[3:], J[3:])


def test_bracket_stiffness_is_the_derivative_of_JT_w(kin):
    rng = np.random.default_rng(4)
    w = rng.normal(size=6) * [5, 5, 5, 1, 1, 1]
    q = random_postures(1, seed=4)[0]
    h = 1e-6
    G_fd = np.empty((7, 7))
    for j in range(7):
        dq = np.zeros(7)
        dq[j] = h
        G_fd[:, j] = (kin.spatial_jacobian(q + dq).T @ w - kin.spatial_jacobian(q - dq).T @ w) / (2 * h)
    assert_allclose(bracket_stiffness(kin.spatial_jacobian(q), w), G_fd, atol=1e-7)


# ------------------------------------------------------------------------ resolved rate
def test_resolved_rate_realises_the_twist(kin):
    rng = np.random.default_rng(5)
    for q in random_postures(5, seed=5):
        V = np.concatenate((rng.normal(scale=0.05, size=3), rng.normal(scale=0.2, size=3)))
        info = kin.resolved_rate(q, V, return_info=True)
        assert info.damping == 0.0 and info.scale == 1.0 and not info.saturated.any()
        assert_allclose(kin.spatial_jacobian(q) @ info.q_dot, V, atol=1e-10)


def test_ik_round_trip_integrating_a_constant_twist(kin):
    """RK4 of q_dot = IK(q, V_g) for 0.5 s reproduces T(t) = exp(t [V_g]) T0."""
    rng = np.random.default_rng(6)
    for q0 in random_postures(3, seed=6, spread=0.4):
        V = np.concatenate((rng.normal(scale=0.04, size=3), rng.normal(scale=0.2, size=3)))
        V[:3] += np.cross(kin.fk(q0)[:3, 3], V[3:])  # a motion of the pad centre, not of the origin
        f = lambda q: kin.resolved_rate(q, V)  # noqa: E731
        q, dt = q0.copy(), 0.01
        for _ in range(50):
            k1 = f(q)
            k2 = f(q + 0.5 * dt * k1)
            k3 = f(q + 0.5 * dt * k2)
            k4 = f(q + dt * k3)
            q = q + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        assert_allclose(kin.fk(q), integrate_spatial(kin.fk(q0), V, 0.5), atol=1e-7)


def test_dls_is_bounded_at_the_stretched_singularity(kin):
    lam = 0.05
    rng = np.random.default_rng(7)
    for q in [np.zeros(7), rng.normal(scale=1e-7, size=7)]:
        for V in [np.array([0.1, 0, 0, 0, 0, 0]), np.array([0, 0, 0.1, 0, 0, 0]), rng.normal(size=6)]:
            info = kin.resolved_rate(q, V, damping=lam, velocity_limits=False, return_info=True)
            assert np.all(np.isfinite(info.q_dot))
            assert info.sigma_min < 1e-6 and info.damping == pytest.approx(lam, rel=1e-6)
            p = kin.fk(q)[:3, 3]
            Vh = np.concatenate((V[:3] - np.cross(p, V[3:]), V[3:]))
            assert np.linalg.norm(info.q_dot) <= np.linalg.norm(Vh) / (2 * lam) + 1e-9
            qd = kin.resolved_rate(q, V, damping=lam)
            assert np.all(np.abs(qd) <= kin.qd_max * (1 + 1e-12))


def test_damping_grows_continuously_towards_the_singularity(kin):
    V = np.array([0.0, 0.0, 0.05, 0.0, 0.0, 0.0])
    prev = None
    for bend in [0.3, 0.1, 0.03, 0.01, 0.0]:
        q = np.array([0.0, bend, 0.0, -2 * bend, 0.0, bend, 0.0])
        info = kin.resolved_rate(q, V, return_info=True)
        assert np.all(np.isfinite(info.q_dot))
        if prev is not None:
            assert info.damping >= prev - 1e-12
        prev = info.damping
    assert prev == pytest.approx(0.05)


def test_joint_driven_into_its_limit_stops_there(kin):
    q = random_postures(1, seed=8, spread=0.3)[0]
    q[0] = Q_MAX[0] - 0.01
    dt = 0.004
    V = kin.spatial_jacobian(q)[:, 0] * 0.5  # the twist of joint 1 turning alone at 0.5 rad/s
    saturated = 0
    for _ in range(20):
        info = kin.resolved_rate(q, V, dt=dt, return_info=True)
        q_next = q + dt * info.q_dot
        assert np.all(q_next <= Q_MAX) and np.all(q_next >= Q_MIN)
        if info.saturated[0]:
            saturated += 1
            # the six other joints take over the Cartesian motion (the arm is redundant)
            assert_allclose(kin.spatial_jacobian(q) @ info.q_dot, V, atol=1e-9)
        q = q_next
    assert saturated >= 5
    assert q[0] == Q_MAX[0]
    # Without dt, a joint sitting on its limit may not move further out.
    assert kin.resolved_rate(q, V)[0] <= 0.0


def test_elbow_in_its_limit_gives_the_best_possible_motion(kin):
    """Only the elbow changes the shoulder-wrist distance: locked, the rest is least squares."""
    q = random_postures(1, seed=8, spread=0.3)[0]
    q[3] = Q_MAX[3]
    V = kin.spatial_jacobian(q)[:, 3] * 0.5
    qd = kin.resolved_rate(q, V, dt=0.004)
    assert qd[3] == 0.0 and np.all(np.isfinite(qd))
    assert np.linalg.norm(kin.spatial_jacobian(q) @ qd - V) < np.linalg.norm(V)


def test_long_push_never_leaves_the_limits_or_goes_nan(kin):
    q = Q_READY.copy()
    V = np.array([0.3, 0.1, 0.2, 0.0, 0.5, 0.3])  # far out of the workspace, spinning
    dt = 0.004
    for _ in range(750):
        q = q + dt * kin.resolved_rate(q, V, dt=dt)
        assert np.all(np.isfinite(q))
        assert np.all(q <= Q_MAX) and np.all(q >= Q_MIN)


def test_velocity_limits_scale_the_whole_vector(kin):
    q = random_postures(1, seed=9)[0]
    V = np.array([2.0, -1.0, 1.5, 3.0, 0.0, -2.0])
    raw = kin.resolved_rate(q, V, velocity_limits=False)
    info = kin.resolved_rate(q, V, return_info=True)
    assert info.scale < 1.0
    assert np.all(np.abs(info.q_dot) <= kin.qd_max * (1 + 1e-12))
    assert_allclose(info.q_dot, raw * info.scale, atol=1e-12)


def test_bad_input_is_rejected(kin):
    with pytest.raises(ValueError):
        kin.fk(np.zeros(6))
    with pytest.raises(ValueError):
        kin.fk(np.full(7, np.nan))
    with pytest.raises(ValueError):
        kin.resolved_rate(Q_READY, [0, 0, np.nan, 0, 0, 0])
    with pytest.raises(ValueError):
        kin.resolved_rate(Q_READY, np.zeros(6), dt=0.0)
    with pytest.raises(ValueError):
        LWR4Kinematics(mount=np.eye(3))


# ------------------------------------------------------------------------------- pose IK
def test_ik_pose_round_trip(kin):
    for q_true in random_postures(4, seed=10, spread=0.5):
        T = kin.fk(q_true)
        q = kin.ik_pose(T)
        assert_allclose(kin.fk(q), T, atol=1e-6)
        assert kin.within_limits(q)


def test_ik_pose_places_the_pad_above_the_table_elbow_up(kin):
    for pos, yaw in [((0.5, 0.0, 0.05), 0.0), ((0.6, 0.2, 0.1), 0.5), ((0.45, -0.25, 0.02), -0.8)]:
        T = kin.pad_down_pose(pos, yaw)
        q = kin.ik_pose(T)
        assert_allclose(kin.fk(q), T, atol=1e-6)
        frames = kin.fk_all(q)
        assert frames[3, 2, 3] > frames[5, 2, 3]  # elbow above the wrist
        assert np.all(q > Q_MIN + 4 * DEG) and np.all(q < Q_MAX - 4 * DEG)
        _, Jh = kin.hybrid_jacobian(q)
        assert np.linalg.svd(Jh, compute_uv=False)[-1] > 0.1  # far from singular


def test_ik_pose_reports_an_unreachable_target(kin):
    with pytest.raises(ValueError, match="did not reach"):
        kin.ik_pose(kin.pad_down_pose((2.0, 0.0, 0.0)), max_iter=100)


# ---------------------------------------------------------------------------- compliance
PAD_CORNERS = np.array([[sx * 0.04, sy * 0.04, 0.0] for sx in (-1, 1) for sy in (-1, 1)]).T


def plane_wrench(height: float, k: float, mode: str = "corners"):
    """Penalty contact of the pad with the horizontal plane z = height (pad facing down).

    ``corners``: the four corners of the 80 mm pad, k/4 each; ``centre``: one point at the
    pad centre, returned with its analytic Cartesian stiffness.
    """
    def corners_fn(T):
        P = T[:3, :3] @ PAD_CORNERS + T[:3, 3:4]
        fz = k / 4 * np.maximum(height - P[2], 0.0)
        return np.array([0.0, 0.0, fz.sum(), (P[1] * fz).sum(), -(P[0] * fz).sum(), 0.0])

    def centre_fn(T):
        p = T[:3, 3]
        pen = height - p[2]
        if pen <= 0.0:
            return np.zeros(6), np.zeros((6, 6))
        F = np.array([0.0, 0.0, k * pen])
        dp = np.hstack((np.eye(3), -skew(p)))  # d p / d xi for a spatial twist xi
        dF = np.zeros((3, 6))
        dF[2] = -k * dp[2]
        dtau = -skew(F) @ dp + skew(p) @ dF
        return point_wrench(p, F), -np.vstack((dF, dtau))

    return corners_fn if mode == "corners" else centre_fn


def test_constant_force_deflects_by_the_joint_compliance(kin):
    arm = CompliantArm(kin)
    w = point_wrench(arm.T_gs[:3, 3], [2.0, -1.0, 5.0])
    res = arm.settle(wrench_g=w, tol=1e-10)
    assert res.converged
    dq = arm.q - arm.q_eq
    J = kin.spatial_jacobian(arm.q)
    assert_allclose(dq, J.T @ w / arm.K, atol=1e-12)  # exact equilibrium K dq = J(q)^T w
    J0 = kin.spatial_jacobian(arm.q_eq)
    assert_allclose(dq, J0.T @ w / arm.K, atol=5e-4)  # first order: K^-1 J^T w
    assert 1e-3 < np.max(np.abs(dq)) < 0.05  # small
    assert_allclose(arm.joint_torque, -J.T @ w, atol=1e-9)


def test_quasi_static_step_converges_to_the_static_deflection(kin):
    arm = CompliantArm(kin)
    w = point_wrench(arm.T_gs[:3, 3], [0.0, 0.0, 5.0])
    for _ in range(40):
        arm.step(0.004, None, wrench_g=w)
    assert_allclose(arm.q - arm.q_eq, kin.spatial_jacobian(arm.q).T @ w / arm.K, atol=1e-6)


def test_dynamic_mode_settles_to_the_same_deflection(kin):
    arm = CompliantArm(kin, mode="dynamic", damping=5.0)
    w = point_wrench(arm.T_gs[:3, 3], [0.0, 0.0, 5.0])
    for _ in range(1500):
        arm.step(0.004, None, wrench_g=w)
    assert_allclose(arm.q - arm.q_eq, kin.spatial_jacobian(arm.q).T @ w / arm.K, atol=1e-6)


@pytest.mark.parametrize("k", [1e2, 1e3, 1e4, 1e5, 1e6, 1e7])
def test_settle_on_a_plane_is_stable_for_any_stiffness(kin, k):
    arm = CompliantArm(kin)
    z0 = arm.T_gs[2, 3]
    pen0 = 0.01  # the equilibrium posture is 10 mm inside the table
    res = arm.settle(wrench_fn=plane_wrench(z0 + pen0, k), tol=1e-6)
    assert res.converged, res
    assert np.all(np.isfinite(res.q)) and np.all(np.isfinite(res.wrench_g))
    J = kin.spatial_jacobian(res.q)
    assert_allclose(arm.K * (res.q - arm.q_eq), J.T @ res.wrench_g, atol=1e-6)
    f = res.wrench_g[2]
    assert 0.0 < f < 10.0  # bounded by the arm's own spring over 10 mm
    P_low = z0 + pen0 - res.T_gs[2, 3]
    assert P_low < pen0  # pushed back out of the table
    assert np.max(np.abs(res.q - arm.q_eq)) < 0.1


@pytest.mark.parametrize("k", [1e2, 1e4, 1e7])
@pytest.mark.parametrize("with_stiffness", [True, False])
def test_settle_matches_springs_in_series(kin, k, with_stiffness):
    """Point contact at the pad centre: f = pen0 / (C_zz + 1/k), C = J_h K^-1 J_h^T."""
    arm = CompliantArm(kin)
    z0 = arm.T_gs[2, 3]
    pen0 = 0.002
    fn = plane_wrench(z0 + pen0, k, mode="centre")
    if not with_stiffness:
        fn = (lambda g: lambda T: g(T)[0])(fn)  # hide K_x: finite differences
    res = arm.settle(wrench_fn=fn, tol=1e-9)
    assert res.converged
    _, Jh = kin.hybrid_jacobian(arm.q_eq)
    C_zz = (Jh @ np.diag(1.0 / arm.K) @ Jh.T)[2, 2]
    assert res.wrench_g[2] == pytest.approx(pen0 / (C_zz + 1.0 / k), rel=0.02)


def test_closed_loop_pressing_on_a_rigid_table(kin):
    """250 Hz, the equilibrium pushed down into a 1e7 N/m table, then a force loop to 2 N."""
    arm = CompliantArm(kin)
    table = arm.T_gs[2, 3] - 0.003
    fn = plane_wrench(table, 1e7)
    dt = 0.004
    forces = []
    for i in range(400):
        f = arm.wrench_g[2]
        vz = -0.02 if i < 100 else 0.01 * (f - 2.0)
        T = arm.move(np.array([0.0, 0.0, vz, 0.0, 0.0, 0.0]), dt, wrench_fn=fn)
        assert arm.last_solve.converged
        forces.append(arm.wrench_g[2])
        corners_z = T[2, :3] @ PAD_CORNERS + T[2, 3]
        assert corners_z.min() > table - 1e-5  # penetration stays below 10 um
    assert np.all(np.isfinite(forces))
    assert forces[-1] == pytest.approx(2.0, abs=0.05)
    # Sudden contact loss: the pad springs back to its equilibrium, finitely.
    for _ in range(10):
        arm.step(dt, None, wrench_fn=lambda T: np.zeros(6))
    assert_allclose(arm.q, arm.q_eq, atol=1e-6)


@pytest.mark.parametrize("rate_hz", [100.0, 1900.0])
@pytest.mark.parametrize("k", [1e2, 1e7])
def test_pressing_is_stable_at_any_control_rate(kin, rate_hz, k):
    arm = CompliantArm(kin)
    table = arm.T_gs[2, 3] - 0.002
    dt = 1.0 / rate_hz
    V = np.array([0.0, 0.0, -0.02, 0.0, 0.0, 0.0])
    for _ in range(int(0.4 * rate_hz)):  # the equilibrium ends 6 mm below the surface
        T = arm.move(V, dt, wrench_fn=plane_wrench(table, k))
        assert arm.last_solve.converged and np.all(np.isfinite(T))
    if k == 1e7:
        assert (T[2, :3] @ PAD_CORNERS + T[2, 3]).min() > table - 1e-5
    assert 0.0 < arm.wrench_g[2] < 6.0


def test_arm_stands_in_for_the_cartesian_mount(kin):
    """``pose`` and ``move(twist_g, dt)`` like the ideal mount; ``contact`` supplies the wrench."""
    arm = CompliantArm(kin)
    V = np.array([0.01, -0.02, 0.0, 0.0, 0.0, 0.1])
    V[:3] += np.cross(arm.pose[:3, 3], V[3:])
    T0 = arm.pose
    for _ in range(25):
        arm.move(V, 0.004)
    T_ref = integrate_spatial(T0, V, 0.1)
    assert_allclose(arm.T_gs_eq, T_ref, atol=2e-5)  # Euler in joint space
    assert_allclose(arm.pose, T_ref, atol=2e-4)  # the joints lag by D/K = 1 ms
    arm.contact = plane_wrench(arm.pose[2, 3] + 0.002, 1e5)
    arm.move(np.zeros(6), 0.004)
    assert arm.wrench_g[2] > 0.0 and arm.pose[2, 3] > arm.T_gs_eq[2, 3]


@pytest.mark.parametrize("k", [1e5, 1e7])
def test_no_tunnelling_through_a_thin_slab(kin, k):
    """A 2 mm slab whose penalty force flips past its mid-plane; the equilibrium 20 mm below it."""
    arm = CompliantArm(kin)
    top, thick = arm.T_gs[2, 3] - 0.0005, 0.002

    def slab(T):
        d = top - T[2, 3]
        f = k * d if 0.0 < d < thick / 2 else (-k * (thick - d) if thick / 2 <= d < thick else 0.0)
        return point_wrench(T[:3, 3], [0.0, 0.0, f])

    q_eq = kin.ik_pose(kin.pad_down_pose(arm.T_gs[:3, 3] - [0.0, 0.0, 0.02]), q0=arm.q)
    res = arm.settle(q_eq=q_eq, wrench_fn=slab)
    assert res.converged
    assert top - thick / 2 < res.T_gs[2, 3] < top  # resting on the top face
    assert res.wrench_g[2] > 1.0


@pytest.mark.parametrize("pen0", [0.01, 0.05])
def test_pad_starting_deep_inside_a_rigid_object_is_pushed_out(kin, pen0):
    arm = CompliantArm(kin)
    fn = plane_wrench(arm.T_gs[2, 3] + pen0, 1e7)
    res = arm.settle(wrench_fn=fn)
    assert res.converged and np.all(np.isfinite(res.q))
    assert 0.0 < res.wrench_g[2] < 1000.0 * pen0


def test_compliant_arm_driven_into_the_stretched_singularity(kin):
    """Nearly stretched up, pulled further up at 0.1 m/s for 2 s: damped, finite, bounded."""
    arm = CompliantArm(kin, q0=[0.0, 0.05, 0.0, -0.1, 0.0, 0.05, 0.0])
    V = np.array([0.0, 0.0, 0.1, 0.0, 0.0, 0.0])
    dt = 0.004
    damped = 0
    for _ in range(500):
        info = kin.resolved_rate(arm.q_eq, V, dt=dt, return_info=True)
        damped += info.damping > 0.0
        T = arm.move(V, dt)
        assert np.all(np.isfinite(arm.q)) and np.all(np.isfinite(T))
        assert np.all(np.abs(arm.q_dot) <= kin.qd_max * (1 + 1e-9))
    assert damped > 100
    assert T[2, 3] <= D1 + D3 + D5 + D7 + MOUNT + 1e-9


def test_wrench_fn_returning_nan_is_an_error(kin):
    arm = CompliantArm(kin)
    with pytest.raises(FloatingPointError):
        arm.step(0.004, None, wrench_fn=lambda T: np.full(6, np.nan))
    assert np.all(np.isfinite(arm.q))


def test_equilibrium_posture_stays_inside_the_limits(kin):
    arm = CompliantArm(kin)
    for _ in range(300):
        arm.step(0.01, np.full(7, 1.5))
        assert np.all(arm.q_eq <= Q_MAX) and np.all(arm.q_eq >= Q_MIN)
    assert_allclose(arm.q_eq, Q_MAX)
