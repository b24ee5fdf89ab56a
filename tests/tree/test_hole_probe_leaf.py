"""The hole_probe leaf: lower the pad's corner into a valley at each of its points, on a
kinematic pad that follows the commanded twist; an open valley, and one with a floor."""

import math

import numpy as np
import numpy.testing as npt
from py_trees.common import Status
from scipy.spatial.transform import Rotation

from tactile_bt.contacts.hole_probe import pad_rotation
from tactile_bt.control.spatial import make_pose
from tactile_bt.testing import LeafHarness, make_features
from tactile_bt.tree.behaviours import HoleProbe
from tactile_bt.tree.behaviours.table import lowest_corner
from test_reapproach import DOWN, DT, fly

HOME = np.array([0.0, 0.0, 0.06])


def _job(depths):
    """A probe of two points 30 mm apart, the corner going down to ``depths`` (m)."""
    probes = [(np.array([0.05 + 0.03 * k, 0.0]), pad_rotation((0.08, 0.08), math.pi * k, math.radians(65)), z)
              for k, z in enumerate(depths)]
    return {"hole": {"probes": probes, "cells": np.zeros((0, 2)), "centre": np.array([0.06, 0.0])},
            "top_z": 0.06, "home": (HOME, np.array([0.0, 0.0, 1.0]))}


def _harness(job):
    leaf = HoleProbe()
    h = LeafHarness(leaf, dt=DT, pose=make_pose(DOWN, HOME))
    h.set("/scan/reapproach", job)
    return h, leaf


def test_an_open_valley_is_probed_at_every_point_down_to_its_height():
    job = _job([0.012, 0.018])
    h, leaf = _harness(job)
    lowest = []

    def at_home(T):  # nothing anywhere but where the pad started
        if not np.allclose(T[:3, 3], HOME, atol=1e-4):
            lowest.append(lowest_corner(T, leaf.pad)[2])
        return np.linalg.norm(T[:3, 3] - HOME) < 1e-4

    status, T = fly(h, at_home, max_ticks=20000)
    assert status == Status.SUCCESS and job["result"] == "open"
    npt.assert_allclose(job["reached"], [0.012, 0.018], atol=0.001)
    assert min(lowest) > 0.012 - 0.001                           # never below the lower height
    npt.assert_allclose(T[:3, 3], HOME, atol=0.003)              # back where it left


def test_a_floor_under_the_first_point_ends_the_probe_touched():
    job = _job([0.005, 0.005])
    h, leaf = _harness(job)
    floor = 0.02

    def on_floor(T):
        return np.linalg.norm(T[:3, 3] - HOME) < 1e-4 or lowest_corner(T, leaf.pad)[2] <= floor

    status, T = fly(h, on_floor, max_ticks=20000)
    assert status == Status.SUCCESS and job["result"] == "touched"
    assert len(job["reached"]) == 1 and abs(job["reached"][0] - floor) < 0.002
    assert np.linalg.norm(job["touched"][:2] - np.array([0.05, 0.0])) < 0.08  # where the pad touched: over the point


def test_a_corner_that_touched_while_lowering_lifts_off_straight_up():
    """The pad came down corner first, tilted 65°: it leaves the way it came, not along its
    normal, which points across the valley at its other side."""
    job = _job([0.005, 0.005])
    h, leaf = _harness(job)
    floor = 0.02
    path, touched = [], []

    def on_floor(T):
        at_home = np.linalg.norm(T[:3, 3] - HOME) < 1e-4
        contact = at_home or lowest_corner(T, leaf.pad)[2] <= floor
        if contact and not at_home and not touched:
            touched.append(T[:3, 3].copy())
        if touched:
            path.append(T[:3, 3].copy())
        return contact

    status, _ = fly(h, on_floor, max_ticks=20000)
    assert status == Status.SUCCESS and job["result"] == "touched"
    path = np.array(path)
    risen = path[np.argmax(path[:, 2] >= touched[0][2] + leaf.lift_m - 0.002)]
    assert risen[2] > touched[0][2]
    assert np.linalg.norm(risen[:2] - touched[0][:2]) < 0.002   # along its normal: 7 mm aside


def test_without_a_pending_probe_it_succeeds_at_once():
    h, _ = _harness(None)
    assert h.tick(make_features()) == Status.SUCCESS


def fly_blocked(h, blocked, max_ticks=30000):
    """As ``fly``, touching only at home, but the pad does not move down where ``blocked(T)``
    (an arm that cannot follow there)."""
    T = make_pose(DOWN, HOME)
    status = Status.RUNNING
    for _ in range(max_ticks):
        home = np.linalg.norm(T[:3, 3] - HOME) < 1e-4
        status = h.tick(make_features(pressure=2000.0) if home else make_features(in_contact=False))
        if status != Status.RUNNING:
            break
        twist = np.asarray(h.command.twist(), dtype=float)
        R = T[:3, :3]
        step = R @ twist[:3] * DT
        if blocked(T) and step[2] < 0:
            step[:] = 0.0
        T = T.copy()
        T[:3, 3] += step
        T[:3, :3] = Rotation.from_rotvec(R @ twist[3:] * DT).as_matrix() @ R
        h.set_pose(T)
    return status, T


def _three(depth=0.015):
    job = _job([depth, depth])
    job["hole"]["probes"].append((np.array([0.02, 0.0]), pad_rotation((0.08, 0.08), 0.5 * math.pi, math.radians(65)),
                                  depth))
    return job


def test_one_point_the_arm_cannot_get_to_leaves_the_valley_open_but_two_do_not():
    for stuck_at, result in (((0.08,), "open"), ((0.08, 0.02), "reach")):
        job = _three()
        h, leaf = _harness(job)

        def blocked(T):  # over these points (world x, m) the pad stops 40 mm above the table
            corner = lowest_corner(T, leaf.pad)
            return any(abs(corner[0] - x) < 0.005 for x in stuck_at) and corner[2] < 0.04

        status, _ = fly_blocked(h, blocked)
        assert status == Status.SUCCESS and job["result"] == result
        xs = [p[0][0] for p in job["hole"]["probes"]]
        assert job["outcomes"] == ["reach" if any(abs(x - s) < 0.005 for s in stuck_at) else "open" for x in xs]
