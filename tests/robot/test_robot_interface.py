"""The Robot protocol: every simulated mount is driven as a live arm would be.

Send a twist, step, and the pad moves along it; stop, and it stays; stamps increase; joints
and limits where the mount has them.
"""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from tactile_bt.robot.interface import JointState, Robot, StampedPose
from tactile_bt.robot.mounts import MOUNT_TYPES, CartesianMount, MountSpec

DT = 0.004  # s, one 250 Hz control period
STEPS = 25  # 0.1 s
TWIST = np.array([0.01, -0.005, 0.002, 0.0, 0.0, 0.2])  # m/s, rad/s, base frame


@pytest.fixture(params=MOUNT_TYPES)
def mount(request):
    return MountSpec(type=request.param).build()


def _run(robot, steps=STEPS):
    stamps = []
    for _ in range(steps):
        robot.step(DT)
        stamps.append(robot.pad_pose().stamp_s)
    return np.array(stamps)


def _motion(a: StampedPose, b: StampedPose):
    """Translation (m) and rotation vector (rad, base frame) from pose a to pose b."""
    rot = Rotation.from_matrix(b.T_gs[:3, :3] @ a.T_gs[:3, :3].T).as_rotvec()
    return b.T_gs[:3, 3] - a.T_gs[:3, 3], rot


def test_every_mount_is_a_robot(mount):
    assert isinstance(mount, Robot)
    pose = mount.pad_pose()
    assert pose.T_gs.shape == (4, 4) and np.allclose(pose.T_gs[3], [0, 0, 0, 1])
    assert pose.stamp_s == 0.0


def test_pad_moves_along_the_twist_sent(mount):
    start = mount.pad_pose()
    mount.send_twist(TWIST)
    stamps = _run(mount)
    moved, turned = _motion(start, mount.pad_pose())
    # A pure base-frame rotation about z moves the pad's origin too (spatial twist); take the
    # expected displacement from the ideal integration of the same twist.
    from tactile_bt.control.spatial import integrate_spatial

    expected = start.T_gs
    for _ in range(STEPS):
        expected = integrate_spatial(expected, TWIST, DT)
    want = expected[:3, 3] - start.T_gs[:3, 3]
    assert np.linalg.norm(moved - want) < 0.05 * np.linalg.norm(want)  # the arm lags a little
    assert np.allclose(turned, TWIST[3:] * STEPS * DT, atol=0.05 * abs(TWIST[5]) * STEPS * DT)
    assert np.all(np.diff(stamps) > 0) and stamps[-1] == pytest.approx(STEPS * DT)


def test_the_twist_is_held_until_the_next(mount):
    mount.send_twist(TWIST)
    _run(mount, 5)
    a = mount.pad_pose()
    _run(mount)
    b = mount.pad_pose()
    speed = np.linalg.norm(b.T_gs[:3, 3] - a.T_gs[:3, 3]) / (b.stamp_s - a.stamp_s)
    assert speed == pytest.approx(np.linalg.norm(TWIST[:3]), rel=0.3)  # still moving, at about the speed sent


def test_stop_gives_zero_motion_and_is_idempotent(mount):
    mount.send_twist(TWIST)
    _run(mount)
    mount.stop()
    mount.stop()
    assert np.array_equal(mount.held_twist, np.zeros(6))
    _run(mount, 5)  # the compliant arm settles on its equilibrium
    a = mount.pad_pose()
    stamps = _run(mount)
    b = mount.pad_pose()
    moved, turned = _motion(a, b)
    elapsed = b.stamp_s - a.stamp_s
    # Exactly still on the ideal mount; on the arm only the null-space joint-limit avoidance
    # leaks into the pad's motion: below 5 % of the twist that was stopped.
    assert np.linalg.norm(moved) / elapsed < 0.05 * np.linalg.norm(TWIST[:3])
    assert np.linalg.norm(turned) / elapsed < 0.05 * abs(TWIST[5])
    assert np.all(np.diff(stamps) > 0)


def test_joint_state_where_the_mount_has_joints(mount):
    state = mount.joint_state()
    if isinstance(mount, CartesianMount):
        assert state is None  # the ideal mount has no joints
        return
    assert isinstance(state, JointState)
    assert state.positions_rad.shape == state.lower_rad.shape == state.upper_rad.shape == (7,)
    assert np.all(state.lower_rad < state.positions_rad) and np.all(state.positions_rad < state.upper_rad)
    assert not state.near_limit(0.1).any()  # the start posture is well inside the limits
    assert state.near_limit(10.0).all()


@pytest.mark.parametrize("bad", [[0.0] * 5, [0, 0, float("nan"), 0, 0, 0], "fast"])
def test_a_bad_twist_is_refused_with_a_clear_error(mount, bad):
    with pytest.raises(ValueError, match=r"twist_g must be 6 finite numbers"):
        mount.send_twist(bad)
    assert np.array_equal(mount.held_twist, np.zeros(6))  # nothing was sent
