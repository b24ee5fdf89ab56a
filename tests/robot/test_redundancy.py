"""The LWR 4's redundancy: the null-space motion keeps the joints off their limits and the wrist
off its singularity without disturbing the pad, and a saturated joint does not make the pad jump."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from tactile_bt.control.spatial import body_to_spatial, make_pose
from tactile_bt.robot.arm import CompliantArm
from tactile_bt.robot.kinematics import Q_MAX, Q_MIN, Q_READY, LWR4Kinematics
from tactile_bt.robot.redundancy import LimitAvoidance, joint_margins

DEG = np.pi / 180.0
REDUNDANT = [0, 1, 2, 4, 5, 6]  # every joint but the elbow, which the swivel cannot move
#: sim/object.yaml started with rpy_deg [180, 0, 0]: joint 7 is 9° from its limit.
Q_OBJECT = np.array([28.7, -36.1, -41.5, 90.0, 25.8, -63.8, 161.1]) * DEG


@pytest.fixture(scope="module")
def kin() -> LWR4Kinematics:
    return LWR4Kinematics()


def posture(seed: int, spread: float = 0.8) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.clip(Q_READY + rng.uniform(-spread, spread, 7), Q_MIN + 0.05, Q_MAX - 0.05)


def near_a_limit(seed: int) -> np.ndarray:
    """A seeded posture with one of the redundant joints 3° to 8° from a limit."""
    rng = np.random.default_rng(100 + seed)
    q = posture(seed)
    j = REDUNDANT[seed % len(REDUNDANT)]
    gap = rng.uniform(3.0, 8.0) * DEG
    q[j] = Q_MAX[j] - gap if rng.random() < 0.5 else Q_MIN[j] + gap
    return q


@pytest.mark.parametrize("seed", range(8))
def test_null_space_motion_leaves_the_pad_twist_unchanged(kin, seed):
    q = near_a_limit(seed) if seed % 2 else posture(seed)
    rng = np.random.default_rng(seed)
    V = np.concatenate((rng.normal(scale=0.02, size=3), rng.normal(scale=0.2, size=3)))
    avoid = LimitAvoidance()
    null = avoid.q_dot(q, kin.q_min, kin.q_max)
    plain = kin.resolved_rate(q, V, return_info=True)
    used = kin.resolved_rate(q, V, q_dot_null=null, null_speed_max=avoid.speed_max, return_info=True)
    J = kin.spatial_jacobian(q)
    assert plain.damping == 0.0 and used.damping == 0.0 and used.scale == 1.0
    assert_allclose(J @ plain.q_dot, V, atol=1e-9)
    assert_allclose(J @ used.q_dot, V, atol=1e-9)
    assert_allclose(used.residual, 0.0, atol=1e-9)
    extra = used.q_dot - plain.q_dot
    assert np.linalg.norm(extra) > 1e-4  # the null term does move the arm ...
    assert abs(extra[3]) < 1e-9  # ... but never the elbow
    assert np.max(np.abs(extra)) <= avoid.speed_max + 1e-12


@pytest.mark.parametrize("seed", range(6))
def test_pure_null_space_motion_raises_the_smallest_margin(kin, seed):
    q = near_a_limit(seed)
    avoid = LimitAvoidance()
    T0 = kin.fk(q)
    before = joint_margins(q, Q_MIN, Q_MAX)[REDUNDANT].min()
    cost = avoid.cost(q, Q_MIN, Q_MAX)
    dt = 0.01
    for _ in range(30):
        null = avoid.q_dot(q, kin.q_min, kin.q_max)
        q = q + dt * kin.resolved_rate(q, np.zeros(6), dt=dt, q_dot_null=null, null_speed_max=avoid.speed_max)
    after = joint_margins(q, Q_MIN, Q_MAX)[REDUNDANT].min()
    assert after > before, (before, after)  # how much depends on the joint's share of the swivel
    assert avoid.cost(q, Q_MIN, Q_MAX) < cost
    T = kin.fk(q)
    assert np.linalg.norm(T[:3, 3] - T0[:3, 3]) < 1e-3  # the pad stays (first-order steps)
    assert np.linalg.norm(T[:3, :3] - T0[:3, :3]) < 1e-2


def test_null_space_motion_turns_the_wrist_away_from_its_singularity(kin):
    """Slowly: near q6 = 0 the self-motion is mostly joints 5 and 7 turning against each other,
    which leaves q6 alone (and the 7-joint Jacobian keeps its rank there)."""
    q = posture(3, spread=1.2)
    q[5] = 0.25  # 14°, inside the 20° band
    avoid = LimitAvoidance()
    T0 = kin.fk(q)
    cost = avoid.cost(q, Q_MIN, Q_MAX)
    for _ in range(100):
        null = avoid.q_dot(q, kin.q_min, kin.q_max)
        q = q + 0.01 * kin.resolved_rate(q, np.zeros(6), dt=0.01, q_dot_null=null, null_speed_max=avoid.speed_max)
    assert q[5] > 0.25 + 0.2 * DEG
    assert avoid.cost(q, Q_MIN, Q_MAX) < cost
    assert np.linalg.norm(kin.fk(q)[:3, 3] - T0[:3, 3]) < 1e-3


def test_limit_avoidance_gradient_matches_the_cost(kin):
    avoid = LimitAvoidance()
    for seed in range(3):
        q = near_a_limit(seed)
        q[5] = 0.1  # inside the wrist band
        g = -avoid.q_dot(q, Q_MIN, Q_MAX) / avoid.gain
        h = 1e-7
        fd = [(avoid.cost(q + h * e, Q_MIN, Q_MAX) - avoid.cost(q - h * e, Q_MIN, Q_MAX)) / (2 * h) for e in np.eye(7)]
        assert_allclose(g, fd, rtol=1e-5, atol=1e-6)
        assert g[3] == 0.0  # the elbow is not in the cost


def test_limit_avoidance_rejects_bad_settings():
    for kwargs in ({"gain": -1.0}, {"speed_max": float("nan")}, {"weights": (1.0,) * 6}, {"weights": (-1.0,) * 7}):
        with pytest.raises(ValueError):
            LimitAvoidance(**kwargs)
    with pytest.raises(TypeError):
        CompliantArm(redundancy=0.5)


def test_the_arm_keeps_joint_7_off_its_limit_while_it_holds(kin):
    """The object scene's start, 9° from the limit of joint 7: holding still, the swivel frees it."""
    arm = CompliantArm(kin, q0=Q_OBJECT)
    T0 = arm.T_gs
    for _ in range(250):  # 1 s at 250 Hz, no contact, no motion commanded
        arm.move(np.zeros(6), 0.004)
    assert Q_MAX[6] - arm.q_eq[6] > 15 * DEG
    assert np.linalg.norm(arm.T_gs[:3, 3] - T0[:3, 3]) < 1e-3
    assert not arm.last_rate.saturated.any()


def test_a_saturated_wrist_joint_does_not_make_the_pad_jump(kin):
    """Turning about the pad normal at 1 rad/s drives joint 7 into its stop (the limit of
    docs/scanning.md); the six others take over until they can't, and the pad stays put:
    before, the damped re-solve moved it sideways by 60 mm in 0.2 s (365 mm in 2 s)."""
    arm = CompliantArm(kin, q0=Q_OBJECT)
    p0 = arm.T_gs[:3, 3].copy()
    dt, twist_s = 0.004, np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0])
    positions, saturated = [], 0
    for _ in range(500):
        arm.move(body_to_spatial(arm.T_gs, twist_s), dt)
        positions.append(arm.T_gs[:3, 3].copy())
        saturated += bool(arm.last_rate.saturated[6])
        assert np.all(arm.q_eq <= Q_MAX) and np.all(arm.q_eq >= Q_MIN)
    positions = np.array(positions)
    assert saturated > 200 and arm.q_eq[6] == pytest.approx(Q_MAX[6])
    step = 50  # 0.2 s
    assert np.linalg.norm(positions[step:] - positions[:-step], axis=1).max() < 2e-3
    assert np.linalg.norm(positions - p0, axis=1).max() < 10e-3
    # what it could not do shows in the residual: the turn, not a translation
    r = arm.last_rate.residual
    assert abs(r[3:] @ arm.T_gs[:3, 2]) > 0.5 and np.linalg.norm(r[:3]) < 0.05


def test_with_the_wrist_on_its_stop_a_retreat_still_moves_the_pad_away():
    """The supervisor's retreat (back along the normal and away from a contact at the border, a
    pure translation) with joint 7 on its upper stop, in a posture of a torus scan: the six other
    joints cannot hold the pad's orientation about its normal as well, and they used to slow the
    whole retreat to under a tenth. Now the pad may turn about its normal: every other part of
    the retreat is made, at full speed. A motion that also turns the pad keeps all of it, slowed
    down on its path (the table guard predicts the corners from it)."""
    arm_kin = LWR4Kinematics(base=make_pose(None, np.array([-0.454, 0.0, 0.181])))  # sim/scan_torus.yaml
    q = np.array([51.9, -112.8, -63.0, 70.0, -90.4, 63.0, 170.0]) * DEG
    q[6] = Q_MAX[6]
    T = arm_kin.fk(q)
    retreat_s = np.array([-0.029, 0.045, -0.05, 0.0, 0.0, 0.0])
    sol = arm_kin.resolved_rate(q, body_to_spatial(T, retreat_s), dt=0.004, return_info=True)
    assert sol.saturated[6] and not sol.saturated[:6].any()
    assert sol.scale > 0.99
    assert np.linalg.norm(sol.residual[:3]) < 1e-6                        # the translation, exactly
    axis = T[:3, 2]
    turn = sol.residual[3:]
    assert np.linalg.norm(turn - (turn @ axis) * axis) < 0.02 * np.linalg.norm(turn) + 1e-9  # only about the normal
    rolling = retreat_s + np.array([0.0, 0.0, 0.0, 0.1, 0.0, 0.0])
    slowed = arm_kin.resolved_rate(q, body_to_spatial(T, rolling), dt=0.004, return_info=True)
    assert slowed.saturated[6] and slowed.scale < 0.5


def test_with_two_wrist_joints_on_their_stops_a_roll_they_cannot_make_is_not_turned_into_a_slide():
    """Joints 5 and 7 wound onto their upper stops going round a ring (a posture of a torus scan)
    and the servo asks a roll of 1.2 rad/s: five joints are left for six parts of the twist. A
    least-squares fit weighing m/s against rad/s made the roll it could not make into a slide of
    the pad of 0.3 m/s, which pressed the pad's corner into the ring. Now the translation asked is
    made, and the turn as far as the joints left can make it, no further from the turn asked than
    holding still."""
    arm_kin = LWR4Kinematics(base=make_pose(None, np.array([-0.472, 0.0, 0.191])))
    q = np.array([-6.7, -85.0, 5.1, 89.4, 170.0, -30.7, 170.0]) * DEG
    q[4], q[6] = Q_MAX[4], Q_MAX[6]
    T = arm_kin.fk(q)
    servo_s = np.array([0.022, -0.017, 0.006, 0.521, 1.2, 0.173])
    V = body_to_spatial(T, servo_s)
    sol = arm_kin.resolved_rate(q, V, dt=0.004, return_info=True)
    assert sol.saturated[4] and sol.saturated[6] and sol.scale == 1.0
    assert_allclose(sol.residual[:3], 0.0, atol=1e-9)                       # the translation, exactly
    assert np.linalg.norm(sol.residual[3:]) < np.linalg.norm(V[3:])          # and some of the turn
    # the same twist that the joints left can make is still made exactly
    turn_left = sol.residual[3:]  # (hybrid twist of the pad centre: the spatial one less p x w)
    doable = V - np.r_[np.cross(T[:3, 3], turn_left), turn_left]
    again = arm_kin.resolved_rate(q, doable, dt=0.004, return_info=True)
    assert_allclose(again.residual, 0.0, atol=1e-6)


def test_with_joint_5_on_its_stop_a_retreat_is_made_at_full_speed():
    """The supervisor's retreat (a pure translation) with joint 5 on its upper stop, in a posture
    of the wide ring's scan: holding the pad's orientation exactly as well needed joint speeds far
    over their limits, and the speed scaling slowed the retreat to a crawl while a corner stayed
    pressed in. The translation comes first: the retreat is made in full, the orientation held as
    far as the joints can without a crawl."""
    arm_kin = LWR4Kinematics(base=make_pose(None, np.array([-0.472, 0.0, 0.191])))
    q = np.array([-21.1, -92.7, 21.5, 88.2, 170.0, -44.3, -33.3]) * DEG
    q[4] = Q_MAX[4]
    T = arm_kin.fk(q)
    retreat_s = np.array([0.011, -0.045, -0.05, 0.0, 0.0, 0.0])
    sol = arm_kin.resolved_rate(q, body_to_spatial(T, retreat_s), dt=0.004, return_info=True)
    assert sol.saturated[4] and sol.saturated.sum() == 1
    assert sol.scale > 0.99
    assert_allclose(sol.residual[:3], 0.0, atol=1e-9)
    assert np.linalg.norm(sol.residual[3:]) < 0.2  # rad/s: the pad turns a little as it backs off


#: Postures of the ring scans with the wrist nearly straight (q6 of 1 to 3 deg) where the six rows
#: of the Jacobian are nearly singular (smallest singular value 0.007 to 0.012 m/rad), no joint
#: on a stop; the base of ``docs/unseen_scans.py``'s rings.
_RING_BASE = make_pose(None, np.array([-0.472, 0.0, 0.191]))
_NEAR_STRAIGHT_WRIST = {
    "wide ring, a corner in its wall": np.array([-34.0, -95.2, 34.1, 88.0, 90.9, 1.5, -3.9]) * DEG,
    "middle ring, bridging its hole": np.array([11.2, -83.7, -15.5, 88.7, -89.3, 2.8, -37.1]) * DEG,
}


@pytest.mark.parametrize("posture", sorted(_NEAR_STRAIGHT_WRIST))
def test_near_a_singularity_a_retreat_leaves_the_wall_at_full_speed(posture):
    """The supervisor's retreat (back along the normal, sliding away from a corner at the border)
    near a singularity of all six rows: damping the weak direction, which mixes a slide with a
    turn, dropped 25 of 45 mm/s of the slide that frees the corner, and the pad rose along the
    ring's wall with the corner still 5 mm in it. The translation comes first and is made in full."""
    arm_kin = LWR4Kinematics(base=_RING_BASE)
    q = _NEAR_STRAIGHT_WRIST[posture]
    T = arm_kin.fk(q)
    retreat_s = np.array([0.044, 0.045, -0.05, 0.0, 0.0, 0.0])
    sol = arm_kin.resolved_rate(q, body_to_spatial(T, retreat_s), dt=0.004, return_info=True)
    assert sol.sigma_min < 0.02 and sol.damping > 0.0 and not sol.saturated.any()
    assert sol.scale > 0.99
    assert_allclose(sol.residual[:3], 0.0, atol=1e-9)
    assert np.linalg.norm(sol.residual[3:]) < 0.2  # rad/s: the pad turns a little as it backs off


@pytest.mark.parametrize("posture", sorted(_NEAR_STRAIGHT_WRIST))
def test_near_a_singularity_a_roll_is_not_turned_into_a_slide(posture):
    """A roll of 0.8 rad/s with a slow slide, near a singularity of all six rows: damping the weak
    direction made a slide of the pad of up to 0.29 m/s nobody asked for (the middle ring's pad
    swept 23 mm sideways in 0.13 s into the hole's wall). Now the slide is made as asked, and what
    is dropped is turn, no more than the whole turn asked."""
    arm_kin = LWR4Kinematics(base=_RING_BASE)
    q = _NEAR_STRAIGHT_WRIST[posture]
    T = arm_kin.fk(q)
    servo_s = np.array([-0.021, -0.002, 0.01, 0.19, 0.79, -0.4])
    V = body_to_spatial(T, servo_s)
    sol = arm_kin.resolved_rate(q, V, dt=0.004, return_info=True)
    assert sol.damping > 0.0 and not sol.saturated.any()
    asked = T[:3, :3] @ servo_s[:3]  # the pad centre's velocity asked, base frame
    made = asked - sol.residual[:3]
    assert 0.3 < sol.scale <= 1.0
    assert_allclose(made, sol.scale * asked, atol=1e-9)  # the slide asked, on its path (slowed by the speed limits)
    assert np.linalg.norm(sol.residual[3:]) < np.linalg.norm(V[3:])


def test_with_the_arm_stretched_and_the_shoulder_on_its_stop_the_pad_keeps_moving():
    """A posture of the wide ring's scan at the arm's reach: the elbow straight (2 deg), joint 2 on
    its lower stop, the servo asking a slide and a roll. With joint 2 held, joints 3 and 5 turning
    against each other is a self-motion of the six left, and the undamped re-solve made the slide
    with them at thousands of rad/s: the speed scaling slowed the pad to nothing, and they
    swung back and forth by half a degree every cycle while the pad stood still for 50 s. There
    the re-solve is damped, the slide made first: the pad moves on its way, slowed at most by
    the other stops it meets (joint 5's)."""
    arm_kin = LWR4Kinematics(base=make_pose(None, np.array([-0.472, 0.0, 0.191])))
    q = np.array([4.46, -120.0, 0.0, 2.02, 169.99, 119.25, -99.3]) * DEG
    q[1] = Q_MIN[1]
    servo_s = np.array([0.0126, -0.0169, 0.0463, 0.547, -0.0985, -0.0182])
    avoid = LimitAvoidance()
    dt, p0 = 0.004, arm_kin.fk(q)[:3, 3]
    q3 = []
    for k in range(25):  # 0.1 s
        T = arm_kin.fk(q)
        sol = arm_kin.resolved_rate(q, body_to_spatial(T, servo_s), dt=dt, q_dot_null=avoid.q_dot(q, Q_MIN, Q_MAX),
                                    null_speed_max=avoid.speed_max, return_info=True)
        asked = T[:3, :3] @ servo_s[:3]
        made = asked - sol.residual[:3]
        assert sol.saturated[1] or k > 0
        assert sol.scale > 0.1  # (it was 6e-5)
        assert made @ asked > 0.25 * (asked @ asked)  # the slide asked, slowed down at most
        q = q + sol.q_dot * dt
        q3.append(q[2])
    moved = np.linalg.norm(arm_kin.fk(q)[:3, 3] - p0)
    assert moved > 0.3 * np.linalg.norm(servo_s[:3]) * 0.1
    assert np.count_nonzero(np.diff(np.sign(np.diff(q3)))) <= 2  # joint 3 does not swing (it turned back 24 times)
