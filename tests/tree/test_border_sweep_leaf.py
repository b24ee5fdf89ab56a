"""The foot_sweep leaf's level pad, and the jobs it leaves to reapproach."""

import math

import numpy as np
import numpy.testing as npt
import pytest
from py_trees.common import Status
from scipy.spatial.transform import Rotation

from tactile_bt.control.spatial import exp_twist, make_pose
from tactile_bt.testing import LeafHarness, make_features
from tactile_bt.tree.behaviours import BorderSweep
from tactile_bt.tree.behaviours.border_sweep import foot_passes, level_facing
from tactile_bt.tree.behaviours.table import lowest_corner

DOWN = Rotation.from_euler("x", 180, degrees=True)


@pytest.mark.parametrize("seed", range(5))
def test_the_level_pad_faces_the_face_with_the_side_that_turns_it_least(seed):
    rng = np.random.default_rng(seed)
    towards = rng.normal(size=2)
    current = (Rotation.from_euler("z", rng.uniform(-math.pi, math.pi)) * DOWN
               * Rotation.from_euler("xy", rng.normal(0, 0.3, 2))).as_matrix()
    R = level_facing(towards, current)
    npt.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    npt.assert_allclose(np.linalg.det(R), 1.0)
    npt.assert_allclose(R[:, 2], [0, 0, -1], atol=1e-12)  # level, facing down
    d = np.array([*towards, 0.0]) / np.linalg.norm(towards)
    assert max(abs(R[:, 0] @ d), abs(R[:, 1] @ d)) == pytest.approx(1.0)  # a side faces the face
    turn = np.linalg.norm(Rotation.from_matrix(R @ current.T).as_rotvec())
    for k in range(4):  # no other side turns it less
        other = R @ Rotation.from_euler("z", k * math.pi / 2).as_matrix()
        assert turn <= np.linalg.norm(Rotation.from_matrix(other @ current.T).as_rotvec()) + 1e-9


def test_a_probe_job_is_reapproach_s_and_the_leaf_passes_it_by():
    h = LeafHarness(BorderSweep(), pose=make_pose(DOWN, np.array([0.0, 0.0, 0.05])))
    h.set("/scan/reapproach", {"probe": (np.zeros(3), np.array([0.0, 0.0, 1.0])), "top_z": 0.05,
                               "home": (np.zeros(3), np.array([0.0, 0.0, 1.0]))})
    assert h.tick(make_features()) == Status.SUCCESS


def test_the_planner_s_verdict_fails_it_at_once():
    h = LeafHarness(BorderSweep(), pose=make_pose(DOWN, np.array([0.0, 0.0, 0.05])))
    h.set("/scan/reapproach", {"verdict": "no reachable frontier left, but ..."})
    assert h.tick(make_features()) == Status.FAILURE


DT = 1.0 / 250.0
LEDGE_Z = 0.02  # a ledge's top for x < 0, 20 mm up; beyond it, down to the table at z = 0


def _ledge_features(T, pad):
    """2 kPa per mm that the pad's border and corner points over the ledge lie below its top,
    the centre of pressure among them; no contact elsewhere."""
    half = pad.half_width_m
    local = np.array([(x, y, 0.0) for x in (-half, 0.0, half) for y in (-half, 0.0, half) if x or y])
    world = local @ T[:3, :3].T + T[:3, 3]
    depth = np.where(world[:, 0] < 0.0, LEDGE_Z - world[:, 2], 0.0)
    touching = depth > 0
    if not np.any(touching):
        return make_features(in_contact=False)
    cop = local[touching][:, :2].mean(axis=0)
    return make_features(cop_px=pad.m_to_px(cop), pressure=float(1e6 * depth.max()))


def test_passes_step_into_a_hollow_and_where_the_border_reaches_the_table_touching_nothing_it_is_empty():
    leaf = BorderSweep()
    h = LeafHarness(leaf, dt=DT, pose=make_pose(DOWN, np.array([-0.03, 0.0, 0.05])))
    h.set("/setup/table_z_m", 0.0)
    side = {"kind": "valley", "out": np.array([-1.0, 0.0]), "along": np.array([0.0, 1.0]),
            "start": np.array([-0.001, -0.03]), "length_m": 0.06, "width_m": 0.02, "step_m": 0.005,
            "rim_z": LEDGE_Z, "rim_rise": 0.0, "normal": np.array([0.0, 0.0, 1.0]), "centre": np.array([-0.001, 0.0])}
    job = {"sweep": side, "foot_z": 0.002, "top_z": LEDGE_Z,
           "home": (np.array([-0.03, 0.0, LEDGE_Z]), np.array([0.0, 0.0, 1.0]))}
    h.set("/scan/reapproach", job)
    T = make_pose(DOWN, np.array([-0.03, 0.0, 0.05]))
    status, lowest = Status.RUNNING, np.inf
    for _ in range(40000):
        status = h.tick(_ledge_features(T, leaf.pad))
        if status != Status.RUNNING:
            break
        T = T @ exp_twist(np.asarray(h.command.twist(), dtype=float), DT)
        h.set_pose(T)
        lowest = min(lowest, float((np.array([[s * 0.04, t * 0.04, 0.0] for s in (-1, 1) for t in (-1, 1)])
                                    @ T[:3, :3].T + T[:3, 3])[:, 2].min()))
    assert status == Status.SUCCESS and job["result"] == "swept"
    empty = np.vstack(job["empty"])
    assert len(empty) and np.all(empty[:, 0] > -0.002)  # beyond the ledge's edge, never on it
    assert lowest > 0.0025  # the pad came down towards the table no closer than its 3 mm


def test_its_message_is_the_sweep_s_phase_after_a_tick_with_nothing_to_do():
    leaf = BorderSweep()
    h = LeafHarness(leaf, dt=DT, pose=make_pose(DOWN, np.array([-0.03, 0.0, 0.05])))
    h.set("/setup/table_z_m", 0.0)
    assert h.tick(make_features(in_contact=False)) == Status.SUCCESS  # nothing pending yet
    side = {"kind": "valley", "out": np.array([-1.0, 0.0]), "along": np.array([0.0, 1.0]),
            "start": np.array([-0.001, -0.03]), "length_m": 0.06, "width_m": 0.02, "step_m": 0.005,
            "rim_z": LEDGE_Z, "rim_rise": 0.0, "normal": np.array([0.0, 0.0, 1.0]), "centre": np.array([-0.001, 0.0])}
    h.set("/scan/reapproach", {"sweep": side, "foot_z": 0.002, "top_z": LEDGE_Z,
                               "home": (np.array([-0.03, 0.0, LEDGE_Z]), np.array([0.0, 0.0, 1.0]))})
    assert h.tick(make_features(in_contact=False)) == Status.RUNNING
    assert leaf.feedback_message in ("lifting off", "rising", "moving over", "lowering to the standoff")


@pytest.mark.parametrize("slope_deg", [30, 40, 55, 70])
def test_a_foot_s_passes_climb_the_face_until_the_band_below_the_frontier_is_swept(slope_deg):
    slope = math.radians(slope_deg)
    normal = np.array([math.sin(slope), 0.0, math.cos(slope)])
    passes, rise = foot_passes(0.002, 0.0113, normal, 0.003)
    npt.assert_allclose(rise / math.sin(slope), 0.003)  # 3 mm apart along the face
    assert 0.0113 - rise <= 0.002 + (passes - 1) * rise < 0.0113  # the last within a step below the frontier
    # a frontier at the foot, or a level surface, needs the first pass only; a high band, eight at most
    assert foot_passes(0.002, 0.002, normal, 0.003)[0] == 1
    assert foot_passes(0.002, 0.01, np.array([0.0, 0.0, 1.0]), 0.003)[0] == 1
    assert foot_passes(0.002, 0.2, normal, 0.003)[0] == 8


def test_a_foot_s_level_pad_is_turned_back_a_quarter_turn_where_the_wrist_is_wound():
    """Any side of the square pad may face the foot: where the wrist has 10° left turning the pad
    about -z, the sweep's level pad is turned a quarter turn the other way from the side that
    turns it least; with room, it is that side."""
    out = np.array([1.0, 0.0])
    run = {"kind": "foot", "out": out, "along": np.array([0.0, 1.0]), "normal": np.array([0.64, 0.0, 0.77]),
           "start": np.array([0.08, -0.05]), "length_m": 0.1, "centre": np.array([0.08, 0.0]), "band_top_z": 0.002}
    start = make_pose(Rotation.from_euler("z", 20, degrees=True).as_matrix() @ DOWN.as_matrix(),
                      np.array([0.0, 0.0, 0.05]))
    turns = {}
    for negative_room in (math.radians(10), math.radians(170)):
        leaf = BorderSweep()
        h = LeafHarness(leaf, pose=start)
        h.set("/robot/turn_room", lambda room=negative_room: (7, math.radians(330) - room, room))
        h.set("/scan/reapproach", {"sweep": run, "foot_z": 0.002, "top_z": 0.05,
                                   "home": (start[:3, 3], np.array([0.0, 0.0, 1.0]))})
        h.tick(make_features())
        npt.assert_allclose(leaf._R[:, 2], [0.0, 0.0, -1.0], atol=1e-9)  # level either way
        turns[negative_room] = Rotation.from_matrix(start[:3, :3].T @ leaf._R).as_rotvec()[2]
    least = Rotation.from_matrix(start[:3, :3].T @ level_facing(-out, start[:3, :3])).as_rotvec()[2]
    assert turns[math.radians(170)] == pytest.approx(least, abs=1e-9)
    assert turns[math.radians(10)] == pytest.approx(least + math.pi / 2, abs=math.radians(1))


def test_a_foot_s_pad_that_cannot_go_home_takes_up_exploring_lying_on_the_face():
    """Where the way back is closed (the point it left lies at the table), the pad goes onto the
    35° face it swept, lying on it high enough up for its corners to clear the table, instead of
    approaching from where it is: there its level border alone touches the face."""
    slope = math.radians(35)
    normal = np.array([math.sin(slope), 0.0, math.cos(slope)])
    run = {"kind": "foot", "out": np.array([1.0, 0.0]), "along": np.array([0.0, 1.0]), "normal": normal,
           "start": np.array([0.08, -0.05]), "length_m": 0.1, "centre": np.array([0.08, 0.0]), "band_top_z": 0.004}
    leaf = BorderSweep()
    h = LeafHarness(leaf, pose=make_pose(DOWN.as_matrix(), np.array([0.1, 0.0, 0.05])))
    h.set("/setup/table_z_m", 0.0)
    h.set("/scan/reapproach", {"sweep": run, "foot_z": 0.0015, "top_z": 0.06,
                               "home": (np.array([0.2, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]))})
    h.tick(make_features())
    leaf._finish("swept")
    standoff, R, phase = leaf._waypoints[-1]
    assert phase == "lowering to the standoff"
    npt.assert_allclose(R[:, 2], -normal, atol=1e-9)  # lying on the face, sensor z into it
    point = standoff - normal * leaf.standoff_m
    assert abs(float((point - np.array([0.08, 0.0, 0.0015])) @ normal)) < 1e-9  # on the face's plane
    assert lowest_corner(make_pose(R, point), leaf.pad)[2] >= leaf.table_clearance_m
    assert point[2] <= 0.06  # no higher than everything touched
