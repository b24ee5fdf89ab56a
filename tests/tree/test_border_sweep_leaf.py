"""The foot_sweep leaf's level pad, and the jobs it leaves to reapproach."""

import math

import numpy as np
import numpy.testing as npt
import pytest
from py_trees.common import Status
from scipy.spatial.transform import Rotation

from tactile_bt.control.spatial import make_pose
from tactile_bt.testing import LeafHarness, make_features
from tactile_bt.tree.behaviours import BorderSweep
from tactile_bt.tree.behaviours.border_sweep import level_facing

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
