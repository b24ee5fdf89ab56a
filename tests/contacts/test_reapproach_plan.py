"""Choosing where to approach a touched surface anew, and what its result does to the frontier
left (contacts layer, pure geometry)."""

import math

import numpy as np
import numpy.testing as npt

from tactile_bt.contacts.frontier_map import GAP, OPEN, FrontierMap
from tactile_bt.contacts.reapproach_plan import ReapproachPlan, clamp_tilt

SLOPE = math.radians(40)


def face_up_to_a_ridge(rng):
    """Samples of a face rising at 40° towards +x up to a ridge along y at x = 0 (the face
    beyond, falling towards +x, untouched)."""
    x = rng.uniform(-0.04, 0.0, 4000)
    y = rng.uniform(-0.03, 0.03, 4000)
    pts = np.column_stack((x, y, 0.05 + x * math.tan(SLOPE)))
    normal = np.array([-math.sin(SLOPE), 0.0, math.cos(SLOPE)])
    return pts, np.tile(normal, (len(pts), 1))


def test_a_frontier_at_a_ridge_the_pad_stalled_at_is_probed_beyond_it_along_the_touched_normal():
    rng = np.random.default_rng(1)
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.08)
    m.add(*face_up_to_a_ridge(rng))
    m.block((0.0, 0.0), 0.04, (1.0, 0.0), cause="stall")  # every attempt over the ridge stalled
    rows, cols, out, reason = m.classify(math.radians(65))
    plan = ReapproachPlan(beyond_m=0.02, radius_m=0.02)
    job = plan.choose(m, rows, cols, out, reason, from_xy=np.array([-0.006, 0.0]), max_tilt_rad=math.radians(65))
    point, normal = job["probe"]
    assert -0.002 <= job["frontier_xy"][0] <= 0.002            # at the ridge
    assert point[0] > 0.015                                    # beyond it
    npt.assert_allclose(normal, [-math.sin(SLOPE), 0.0, math.cos(SLOPE)], atol=1e-9)
    npt.assert_allclose(job["top_z"], 0.05, atol=0.002)
    # the surface found there: the ridge's frontier is open to sliding again
    job["result"] = "surface"
    assert plan.apply(m, job) == "surface"
    rows, cols, out, reason = m.classify(math.radians(65))
    near = np.linalg.norm(m.centre_of(rows, cols) - job["frontier_xy"], axis=1) < 0.015
    assert set(reason[near]) == {OPEN}
    # the next one is not chosen within 20 mm of the first
    nxt = plan.choose(m, rows, cols, out, reason, from_xy=job["frontier_xy"], max_tilt_rad=math.radians(65))
    assert nxt is not None and np.linalg.norm(nxt["frontier_xy"] - job["frontier_xy"]) > 0.02


def test_the_table_found_beyond_a_frontier_explains_it():
    rng = np.random.default_rng(2)
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.08)
    m.add(*face_up_to_a_ridge(rng))
    m.block((0.0, 0.0), 0.04, (1.0, 0.0), cause="stall")
    rows, cols, out, reason = m.classify(math.radians(65))
    plan = ReapproachPlan()
    job = plan.choose(m, rows, cols, out, reason, np.array([0.0, 0.0]), math.radians(65))
    job["result"] = "table"
    plan.apply(m, job)
    left = m.remainder(math.radians(65))
    assert left.get("table", 0.0) > 0.02


def test_a_normal_steeper_than_the_limit_is_turned_up_to_it():
    n = np.array([math.sin(math.radians(80)), 0.0, math.cos(math.radians(80))])
    c = clamp_tilt(n, math.radians(60))
    npt.assert_allclose(c, [math.sin(math.radians(60)), 0.0, math.cos(math.radians(60))])
    npt.assert_allclose(clamp_tilt(np.array([0.0, 0.0, 1.0]), 0.5), [0.0, 0.0, 1.0])


def _probed_edge(rng, touched_x):
    """A level top at 50 mm ending in an edge along y at x = 0 that every attempt stalled at,
    probed once; the probe touched at ``touched_x`` (m)."""
    x = rng.uniform(-0.06, 0.0, 6000)
    y = rng.uniform(-0.06, 0.06, 6000)
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.1)
    m.add(np.column_stack((x, y, np.full_like(x, 0.05))), np.tile([0.0, 0.0, 1.0], (len(x), 1)))
    m.block((0.0, 0.0), 0.07, (1.0, 0.0), cause="stall")
    rows, cols, out, reason = m.classify(math.radians(65))
    plan = ReapproachPlan()
    job = plan.choose(m, rows, cols, out, reason, np.array([-0.01, 0.0]), math.radians(65))
    job.update(result="surface", touched=np.array([touched_x, job["frontier_xy"][1], 0.05]))
    return m, plan, job


def test_a_probe_that_lands_back_on_the_touched_side_is_followed_by_a_level_probe_beyond_the_edge():
    m, plan, job = _probed_edge(np.random.default_rng(3), touched_x=-0.015)
    assert plan.apply(m, job, far_m=0.06, table_z_m=0.0, half_width_m=0.04) == "near side"
    rows, cols, out, reason = m.classify(math.radians(65))
    assert "stall" in set(reason)                                   # nothing explained yet
    far = plan.choose(m, rows, cols, out, reason, np.array([-0.01, 0.0]), math.radians(65))
    point, normal = far["probe"]
    npt.assert_allclose(far["frontier_xy"], job["frontier_xy"])    # the same frontier,
    assert point[0] > job["frontier_xy"][0] + 0.055                 # with the whole pad beyond it,
    npt.assert_allclose(normal, [0.0, 0.0, 1.0])                    # level,
    npt.assert_allclose(far["approach_m"], 0.05, atol=0.002)        # lowered down to the table
    # it came down to the table touching nothing: the edge along the pad's width is explained
    far["result"] = "table"
    plan.apply(m, far, far_m=0.06, table_z_m=0.0, half_width_m=0.04)
    rows, cols, out, reason = m.classify(math.radians(65))
    along = np.abs(m.centre_of(rows, cols)[:, 1] - job["frontier_xy"][1])
    assert set(reason[(along < 0.035) & (m.centre_of(rows, cols)[:, 0] > -0.004)]) - {GAP} == {"table"}


def test_a_probe_that_touched_beyond_the_edge_opens_it_again():
    m, plan, job = _probed_edge(np.random.default_rng(4), touched_x=0.018)
    assert plan.apply(m, job, far_m=0.06, table_z_m=0.0, half_width_m=0.04) == "surface"
    assert plan.far is None



def _left(m, job):
    """:meth:`FrontierMap.classify`'s output with every frontier cell farther than 15 mm from
    ``job``'s explained (taken for the table's): only the stretch near the probed place is left."""
    rows, cols, out, reason = m.classify(math.radians(65))
    far = np.linalg.norm(m.centre_of(rows, cols) - job["frontier_xy"], axis=1) > 0.015
    reason = reason.astype(object)
    reason[far & (reason != GAP)] = "table"
    return rows, cols, out, reason


def _edge_probed_and_stalled_again(rng):
    """The edge of :func:`_probed_edge`, probed once (the probe found the surface and opened it
    again), then stalled at once more within 20 mm of that probe; nothing else is left."""
    m, plan, job = _probed_edge(rng, touched_x=0.018)
    plan.apply(m, job, far_m=0.06, table_z_m=0.0, half_width_m=0.04)
    m.block(job["frontier_xy"], 0.015, (1.0, 0.0), cause="stall")
    return m, plan, job


def test_frontier_a_re_approach_did_not_explain_is_probed_far_beyond_once_nothing_else_is_left():
    m, plan, job = _edge_probed_and_stalled_again(np.random.default_rng(5))
    rows, cols, out, reason = _left(m, job)
    assert "stall" in set(reason)
    # without the table's height the plan has nothing left to try there
    assert plan.choose(m, rows, cols, out, reason, np.array([-0.01, 0.0]), math.radians(65)) is None
    far = plan.choose(m, rows, cols, out, reason, np.array([-0.01, 0.0]), math.radians(65),
                      far_m=0.06, table_z_m=0.0)
    assert far is not None and far["far"]
    assert np.linalg.norm(far["frontier_xy"] - job["frontier_xy"]) <= 0.015
    point, normal = far["probe"]
    assert point[0] > far["frontier_xy"][0] + 0.055               # the whole pad beyond the edge,
    npt.assert_allclose(normal, [0.0, 0.0, 1.0])                  # level,
    npt.assert_allclose(far["approach_m"], 0.05, atol=0.002)      # lowered down to the table
    far["result"] = "table"
    plan.apply(m, far, far_m=0.06, table_z_m=0.0, half_width_m=0.04)
    rows, cols, out, reason = _left(m, job)
    assert "stall" not in set(reason)                             # the table explains it now


def test_a_frontier_far_probed_once_is_not_far_probed_again():
    m, plan, job = _edge_probed_and_stalled_again(np.random.default_rng(6))
    kw = dict(far_m=0.06, table_z_m=0.0)
    far = plan.choose(m, *_left(m, job), np.array([-0.01, 0.0]), math.radians(65), **kw)
    far["result"] = "surface"                                     # something stands beyond: slide there again
    plan.apply(m, far, far_m=0.06, table_z_m=0.0, half_width_m=0.04)
    m.block(job["frontier_xy"], 0.015, (1.0, 0.0), cause="stall")  # and it stalled once more
    rows, cols, out, reason = _left(m, job)
    assert "stall" in set(reason)
    assert plan.choose(m, rows, cols, out, reason, np.array([-0.01, 0.0]), math.radians(65), **kw) is None
