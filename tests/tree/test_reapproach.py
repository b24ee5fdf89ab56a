"""The reapproach leaf: lift off, move clear and approach a probe point anew along its normal,
on a kinematic pad that follows the commanded twist."""

import math

import numpy as np
import numpy.testing as npt
import py_trees
import pytest
from py_trees.common import Status
from scipy.spatial.transform import Rotation

from tactile_bt.control.spatial import make_pose
from tactile_bt.testing import LeafHarness, make_features
from tactile_bt.tree.behaviours import Reapproach, ReturnToSurface

DOWN = Rotation.from_euler("x", 180, degrees=True)
DT = 1.0 / 250.0


def fly(h, touching, max_ticks=6000, reach=None):
    """Tick, moving the pad by the commanded twist (sensor frame); in contact with 2 kPa where
    ``touching(pose)``; ``reach(position)``, when given, is where the arm stops a position it
    cannot get to. The status and the pose at the end."""
    T = np.asarray(py_trees.blackboard.Blackboard.storage["/tactile/pose"], dtype=float).copy()
    status = Status.RUNNING
    for _ in range(max_ticks):
        contact = touching(T)
        status = h.tick(make_features(pressure=2000.0) if contact else make_features(in_contact=False))
        if status != Status.RUNNING:
            break
        twist = np.asarray(h.command.twist(), dtype=float)
        R = T[:3, :3]
        T = T.copy()
        T[:3, 3] += R @ twist[:3] * DT
        T[:3, :3] = Rotation.from_rotvec(R @ twist[3:] * DT).as_matrix() @ R
        if reach is not None:
            T[:3, 3] = reach(T[:3, 3])
        h.set_pose(T)
    return status, T


def test_the_pad_lifts_off_moves_over_and_lands_on_the_probe_along_its_normal():
    tilt = math.radians(35)
    normal = np.array([math.sin(tilt), 0.0, math.cos(tilt)])
    probe = np.array([0.06, 0.02, 0.03])
    start = make_pose(DOWN, np.array([0.0, 0.0, 0.05]))
    leaf = Reapproach()
    h = LeafHarness(leaf, dt=DT, pose=start)
    job = {"frontier_xy": np.array([0.04, 0.02]), "probe": (probe, normal), "top_z": 0.05,
           "home": (np.array([0.0, 0.0, 0.05]), np.array([0.0, 0.0, 1.0]))}
    h.set("/scan/reapproach", job)

    def on_plane(T):  # a patch of surface around the probe point; at the start the pad touches its home
        d = T[:3, 3] - probe
        height = float(d @ normal)
        patch = np.linalg.norm(d - height * normal) < 0.03 and height <= 0.0
        return patch or np.linalg.norm(T[:3, 3] - start[:3, 3]) < 1e-4

    status, T = fly(h, on_plane)
    assert status == Status.SUCCESS and job["result"] == "surface"
    npt.assert_allclose(T[:3, 2], -normal, atol=math.radians(3))        # facing the surface
    assert np.linalg.norm(T[:3, 3] - probe) < 0.005                     # on the probe point


def test_without_a_pending_re_approach_it_succeeds_at_once():
    h = LeafHarness(Reapproach(), dt=DT, pose=make_pose(DOWN, np.array([0.0, 0.0, 0.05])))
    assert h.tick(make_features()) == Status.SUCCESS


def test_a_pad_whose_wrist_is_wound_near_its_limit_lands_turned_back_a_quarter_turn():
    """The square pad senses the same turned by a quarter turn: a re-approach whose wrist has
    10° left turning the pad about -z lands turned about +z, and one with room lands as it was."""
    probe, normal = np.array([0.05, 0.0, 0.03]), np.array([0.0, 0.0, 1.0])
    start = make_pose(DOWN, np.array([0.0, 0.0, 0.05]))
    turns = {}
    for negative_room in (math.radians(10), math.radians(170)):
        h = LeafHarness(Reapproach(), dt=DT, pose=start)
        h.set("/robot/turn_room", lambda room=negative_room: (7, math.radians(330) - room, room))
        job = {"probe": (probe, normal), "top_z": 0.03, "home": (start[:3, 3], normal)}
        h.set("/scan/reapproach", job)
        status, T = fly(h, lambda T: T[2, 3] <= probe[2] + 1e-4)
        assert status == Status.SUCCESS and job["result"] == "surface"
        npt.assert_allclose(T[:3, 2], -normal, atol=math.radians(2))
        turns[negative_room] = Rotation.from_matrix(start[:3, :3].T @ T[:3, :3]).as_rotvec()[2]
    assert turns[math.radians(10)] == pytest.approx(math.pi / 2, abs=math.radians(3))  # away from the limit
    assert turns[math.radians(170)] == pytest.approx(0.0, abs=math.radians(3))


def test_a_touch_that_found_nothing_is_followed_by_a_return_to_the_last_contact():
    # the pad lost its contact on a 40° face and drifted 90 mm sideways while it approached
    # along its normal; return_to_surface names the last contact, reapproach takes the pad back
    tilt = math.radians(40)
    normal = np.array([-math.sin(tilt), 0.0, math.cos(tilt)])
    last = np.array([-0.03, 0.01, 0.025])
    drifted = make_pose(DOWN, np.array([0.06, 0.01, 0.03]))
    leaf = ReturnToSurface()
    h = LeafHarness(leaf, dt=DT, pose=drifted)
    assert h.tick(make_features(in_contact=False)) == Status.FAILURE
    assert "none recorded" in leaf.feedback_message
    assert py_trees.blackboard.Blackboard.storage.get("/scan/reapproach") is None
    h.contacts.extend(np.array([[-0.02, 0.0, 0.04], [-0.025, 0.005, 0.03], last]), normal, 2000.0, 0.0)
    assert h.tick(make_features(in_contact=False)) == Status.FAILURE
    assert "returning to the last contact at (-30, 10, 25) mm" in leaf.feedback_message
    job = py_trees.blackboard.Blackboard.storage["/scan/reapproach"]
    npt.assert_allclose(job["probe"][0], last)
    npt.assert_allclose(job["probe"][1], normal)
    assert job["top_z"] == pytest.approx(0.04) and job["return"]

    # a job carried out but not yet taken in by the planner goes with the return; one taken in does not
    found = {"far": True, "result": "table"}
    h.set("/scan/reapproach", found)
    assert h.tick(make_features(in_contact=False)) == Status.FAILURE
    assert py_trees.blackboard.Blackboard.storage["/scan/reapproach"]["pending"] is found
    found["applied"] = True
    h.set("/scan/reapproach", found)
    assert h.tick(make_features(in_contact=False)) == Status.FAILURE
    assert "pending" not in py_trees.blackboard.Blackboard.storage["/scan/reapproach"]

    back = Reapproach()
    h = LeafHarness(back, dt=DT, pose=drifted)
    h.set("/scan/reapproach", job)

    def on_face(T):  # the face around the last contact
        d = T[:3, 3] - last
        height = float(d @ normal)
        return np.linalg.norm(d - height * normal) < 0.03 and height <= 0.0

    status, T = fly(h, on_face)
    assert status == Status.SUCCESS and job["result"] == "surface"
    npt.assert_allclose(T[:3, 2], -normal, atol=math.radians(3))  # facing the face again
    assert np.linalg.norm(T[:3, 3] - last) < 0.005


@pytest.mark.parametrize("short_m, result", [(0.005, "surface"), (0.015, "reach")])
def test_a_move_over_the_arm_cannot_finish_goes_on_down_from_near_enough(short_m, result):
    """High up, the arm stops the pad ``short_m`` before the point it moves over to (a point
    near its base is out of reach there, not lower down): within 10 mm across, clear of
    everything touched, the pad goes on down and lands; farther off, the arm's reach ends it."""
    probe, normal = np.array([0.06, 0.02, 0.03]), np.array([0.0, 0.0, 1.0])
    start = make_pose(DOWN, np.array([0.0, 0.02, 0.065]))
    job = {"probe": (probe, normal), "top_z": 0.04, "home": (start[:3, 3], normal)}
    h = LeafHarness(Reapproach(), dt=DT, pose=start)
    h.set("/scan/reapproach", job)

    def reach(p):  # above 55 mm, the arm gets no farther than short_m before x = 60 mm
        return np.array([min(p[0], probe[0] - short_m), p[1], p[2]]) if p[2] > 0.055 else p

    status, T = fly(h, lambda T: T[2, 3] <= probe[2] + 1e-4, reach=reach)
    assert status == Status.SUCCESS and job["result"] == result
    if result == "surface":
        assert np.linalg.norm(T[:3, 3] - probe) < 0.003
