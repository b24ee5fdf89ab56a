"""The frontier map of a touched surface: its frontier, its blocked directions and the reasons
it gives for the frontier left (contacts layer, pure geometry)."""

import math

import numpy as np
import numpy.testing as npt
import pytest

from scipy import ndimage

from tactile_bt.contacts.frontier_map import EXPLAINING, GAP, HOLE, HOLE_RIM_M, OPEN, FrontierMap
from tactile_bt.contacts.untouched import face_going_on, untouched_below, untouched_beyond
from scan_helpers import disc


def test_frontier_is_the_rim_of_the_touched_disc_with_outward_directions():
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.1)
    m.add(*disc(0.02))
    rows, cols, out = m.frontier()
    xy = m.centre_of(rows, cols)
    r = np.linalg.norm(xy, axis=1)
    assert len(rows) > 40
    assert np.all(np.abs(r - 0.02) < 0.004)
    radial = xy / r[:, None]
    assert np.all(np.sum(radial * out, axis=1) > 0.7)


def test_thin_gaps_and_small_holes_are_not_frontier_but_a_wide_gap_is():
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.05)
    pts, normals = disc(0.03, step=0.0005)
    for lo, hi in ((0.0, 0.002), (0.011, 0.0172)):  # a gap one cell wide, one three cells wide
        keep = ~((pts[:, 0] >= lo) & (pts[:, 0] < hi))
        pts, normals = pts[keep], normals[keep]
    hole = (np.abs(pts[:, 0] + 0.010) < 0.0015) & (np.abs(pts[:, 1]) < 0.001)  # a small hole
    m.add(pts[~hole], normals[~hole])
    rows, cols, _ = m.frontier()
    x = m.centre_of(rows, cols)[:, 0]
    inner = np.linalg.norm(m.centre_of(rows, cols), axis=1) < 0.025
    assert not np.any(inner & (np.abs(x - 0.001) < 0.002))     # the thin gap is covered
    assert not np.any(inner & (np.abs(x + 0.010) < 0.003))     # the small hole too
    assert np.any(inner & (x > 0.008) & (x < 0.02))            # the wide gap is open


def test_blocking_covers_a_disc_and_the_neighbouring_directions_only():
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.05)
    m.block((0.01, 0.0), 0.005, (1.0, 0.0))
    r, c = m.cell_of(np.array([[0.01, 0.0], [0.02, 0.0]])).T
    assert m.blocked[r[0], c[0]].tolist() == [True, True, False, False, False, False, False, True]
    assert not m.blocked[r[1], c[1]].any()


def test_what_a_re_approach_found_outlasts_a_later_slide_ending_there_until_the_surface_is_found():
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.06)
    m.add(*disc(0.03))
    m.close((0.03, 0.0), 0.01, "table")                # a probe beyond came down to the table
    m.block((0.03, 0.0), 0.006, (1.0, 0.0), cause="stall")  # a slide stalled there since
    rows, cols, out, reason = m.classify(math.radians(60))
    near = np.linalg.norm(m.centre_of(rows, cols) - (0.03, 0.0), axis=1) < 0.006
    assert set(reason[near]) - {GAP} == {"table"}
    m.unblock((0.03, 0.0), 0.01)                          # a re-approach found the surface beyond
    m.block((0.03, 0.0), 0.006, (1.0, 0.0), cause="stall")
    rows, cols, out, reason = m.classify(math.radians(60))
    near = np.linalg.norm(m.centre_of(rows, cols) - (0.03, 0.0), axis=1) < 0.006
    assert "stall" in set(reason[near]) and "table" not in set(reason[near])


@pytest.mark.parametrize("found, later, reason", [("nothing", "reach", "reach"), ("table", "wrist", "wrist"),
                                                  ("nothing", "stall", "stall")])
def test_only_an_explaining_finding_outlasts_a_later_end_and_an_explaining_end_replaces_it(found, later, reason):
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.06)
    m.add(*disc(0.03))
    m.close((0.03, 0.0), 0.01, found)
    rows, cols, out = m.frontier()
    near = np.linalg.norm(m.centre_of(rows, cols) - (0.03, 0.0), axis=1) < 0.006
    m.block_cells(rows[near], cols[near], out[near], cause=later)
    got = m.classify(math.radians(60))[3]
    near = np.linalg.norm(m.centre_of(*m.classify(math.radians(60))[:2]) - (0.03, 0.0), axis=1) < 0.006
    assert set(got[near]) - {GAP} == {reason}


def test_the_frontier_left_is_explained_by_the_table_the_tilt_and_the_blocks_causes():
    # a dome seen from above: flat top, rim tilted 75° (steeper than a 60° limit) on the -x side,
    # its foot at the table on the +y side, blocked by an edge on the +x side; -y stays open
    rng = np.random.default_rng(0)
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.06)
    pts, normals = disc(0.03, step=0.0005)
    pts = pts + rng.normal(0.0, 1e-5, pts.shape)
    steep = pts[:, 0] < -0.024
    normals[steep] = (-math.sin(math.radians(75)), 0.0, math.cos(math.radians(75)))
    foot = pts[:, 1] > 0.024
    pts[foot, 2] = 0.001
    m.add(pts, normals)
    m.block((0.03, 0.0), 0.012, (1.0, 0.0), cause="edge")
    rows, cols, out, reason = m.classify(math.radians(60), table_z_m=0.0, table_clearance_m=0.003)
    xy = m.centre_of(rows, cols)
    sampled = reason != GAP
    assert set(reason[sampled & (xy[:, 0] < -0.026)]) == {"tilt"}
    assert set(reason[sampled & (xy[:, 1] > 0.026)]) == {"table"}
    assert set(reason[sampled & (xy[:, 0] > 0.026) & (np.abs(xy[:, 1]) < 0.006)]) == {"edge"}
    assert set(reason[sampled & (xy[:, 1] < -0.026) & (np.abs(xy[:, 0]) < 0.01)]) == {OPEN}
    left = m.remainder(math.radians(60), table_z_m=0.0, table_clearance_m=0.003)
    npt.assert_allclose(sum(left.values()), len(rows) * m.cell_m)
    assert left[OPEN] > left["edge"] > 0.0


def test_without_a_table_or_blocks_the_whole_rim_is_open():
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.06)
    m.add(*disc(0.02))
    left = m.remainder(math.radians(70))
    assert set(left) <= {OPEN, GAP}
    npt.assert_allclose(left[OPEN], 2 * math.pi * 0.02, rtol=0.35)  # the rim's length, in cells


def _side(profile, n=8000, seed=3):
    """Samples of a side rising in +x from x = 0, ``profile(x) -> (z, tilt)``, 40 mm wide in y."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(0.0, 0.04, n)
    y = rng.uniform(-0.02, 0.02, n)
    z, tilt = profile(x)
    return np.column_stack((x, y, z)), np.column_stack((-np.sin(tilt), np.zeros(n), np.cos(tilt)))


def _left_near_table(points, normals):
    m = FrontierMap((0.02, 0.0), cell_m=0.002, extent_m=0.08)
    m.add(points, normals)
    m.samples = points
    rows, cols, out = m.frontier()
    low = m.centre_of(rows, cols)[:, 0] < 0.003  # the frontier along x = 0, the table below it
    return m, rows[low], cols[low], out[low]


def _below(m, rows, cols, out, steep_deg=65, **kwargs):
    return untouched_below(m, rows, cols, out, 0.0, math.radians(steep_deg), m.samples, 0.002, **kwargs)


def test_a_plane_face_going_on_to_the_table_leaves_the_run_down_to_it_untouched():
    # a 30° face from x = 0 (z = 10 mm) up: it goes on down to the table at z = 0, 17 mm further out
    slope = math.radians(30)
    m, rows, cols, out = _left_near_table(*_side(lambda x: (0.01 + x * math.tan(slope), np.full_like(x, slope))))
    assert np.all(face_going_on(m, rows, cols, out, math.radians(65), 0.0))
    area = _below(m, rows, cols, out)
    # less the first 2 mm of the face below the frontier's samples, which they cover
    npt.assert_allclose(area, 0.04 * (0.01 / math.tan(slope) - 0.002 * math.cos(slope)), rtol=0.25)
    assert _below(m, rows, cols, out, steep_deg=25) == 0.0  # steeper than the pad may tilt
    # a pad reaching 10 mm from the contact lying on that face has no corner at the table: the
    # table did not stop it there
    assert _below(m, rows, cols, out, reach_m=0.01) == 0.0


@pytest.mark.parametrize("yaw_deg", [0, 20, 30, 45])
def test_the_band_below_a_face_is_the_same_whichever_way_the_face_is_turned(yaw_deg):
    # the 30° face of the test above, 40 mm of it, turned about z: its frontier cells lie closer
    # than a cell apart and point every which way where its foot runs across the grid; the band
    # is 40 mm × (17.3 mm less the 1.7 mm the frontier's samples cover) all the same
    slope, yaw = math.radians(30), math.radians(yaw_deg)
    points, normals = _side(lambda x: (0.01 + x * math.tan(slope), np.full_like(x, slope)), n=20000)
    turn = np.array([[math.cos(yaw), -math.sin(yaw), 0.0], [math.sin(yaw), math.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    points, normals = points @ turn.T, normals @ turn.T
    m = FrontierMap((0.02 * math.cos(yaw), 0.02 * math.sin(yaw)), cell_m=0.002, extent_m=0.1)
    m.add(points, normals)
    m.samples = points
    rows, cols, out = m.frontier()
    c = m.centre_of(rows, cols)
    low = (c @ turn[:2, 0] < 0.003) & (np.abs(c @ turn[:2, 1]) < 0.02)
    area = _below(m, rows[low], cols[low], out[low])
    npt.assert_allclose(area, 0.04 * (0.01 / math.tan(slope) - 0.002 * math.cos(slope)), rtol=0.1)


def test_a_strip_of_contacts_near_the_foot_covers_the_band_around_it():
    # the 30° face touched from z = 10 mm up, and a border's strip of contacts at z = 2 mm
    slope = math.radians(30)
    points, normals = _side(lambda x: (0.01 + x * math.tan(slope), np.full_like(x, slope)))
    m, rows, cols, out = _left_near_table(points, normals)
    before = _below(m, rows, cols, out)
    y = np.linspace(-0.02, 0.02, 41)
    strip = np.column_stack((np.full_like(y, -0.008 / math.tan(slope)), y, np.full_like(y, 0.002)))
    m.samples = np.vstack((points, strip))
    after = _below(m, rows, cols, out)
    # 17.3 mm of run: 1.7 mm below the frontier, and 1.7 mm either side of the strip, covered
    npt.assert_allclose(after, 0.04 * (0.01 / math.tan(slope) - 3 * 0.002 * math.cos(slope)), rtol=0.25)
    assert before - after > 0.04 * 0.003


def test_a_side_touched_beneath_the_walk_where_it_turns_steeper_counts_as_touched():
    # the 30° face touched from z = 10 mm up; below the frontier the side turns to 60° and was
    # touched there (a border sweep): it meets the table 5.8 mm out, where a walk on down at 30°
    # is still 6.7 mm above it, and the walk's steps over that touched side count as touched
    slope, steep = math.radians(30), math.radians(60)
    points, normals = _side(lambda x: (0.01 + x * math.tan(slope), np.full_like(x, slope)))
    m, rows, cols, out = _left_near_table(points, normals)
    before = _below(m, rows, cols, out)
    rng = np.random.default_rng(5)
    x = rng.uniform(-0.01 / math.tan(steep), 0.0, 4000)
    side = np.column_stack((x, rng.uniform(-0.02, 0.02, 4000), 0.01 + x * math.tan(steep)))
    m.samples = np.vstack((points, side))
    after = _below(m, rows, cols, out)
    # 17.3 mm of run: 1.7 mm below the frontier covered, and now the 5.8 mm over the steeper side
    # and the coverage radius beyond it
    npt.assert_allclose(before, 0.04 * (0.01 / math.tan(slope) - 0.0017), rtol=0.25)
    npt.assert_allclose(after, 0.04 * (0.01 / math.tan(slope) - 0.01 / math.tan(steep) - 0.002), rtol=0.25)


def test_a_level_top_far_above_the_table_leaves_nothing_counted_below_it():
    # a box's top, 40 mm above the table: a pad lying on it never meets the table; where the table
    # stopped it, the pad had rolled over an edge onto a side steeper than anything touched
    m, rows, cols, out = _left_near_table(*_side(lambda x: (np.full_like(x, 0.04), np.zeros_like(x))))
    assert _below(m, rows, cols, out, reach_m=0.057) == 0.0


def test_a_side_rounding_off_towards_the_table_leaves_nothing_counted_below_it():
    # a circle of 46 mm radius about x = 40 mm, steepening from 0° there to 60° at the frontier
    r = 0.04 / math.sin(math.radians(60))

    def rounded(x):
        tilt = np.arcsin((0.04 - x) / r)
        return r * np.cos(tilt) - 0.01, tilt

    m, rows, cols, out = _left_near_table(*_side(rounded))
    assert not np.any(face_going_on(m, rows, cols, out, math.radians(65), 0.0))
    assert _below(m, rows, cols, out) == 0.0


def _beyond(m, rows, cols, out):
    return untouched_beyond(m, rows, cols, out, math.radians(65), m.samples, 0.002, table_z_m=0.0)


def test_a_face_beyond_the_arms_reach_counts_the_10_mm_its_shape_was_measured_over_untouched():
    # a level top 40 mm above the table that the arm stopped the pad on at x = 0: it goes on
    m, rows, cols, out = _left_near_table(*_side(lambda x: (np.full_like(x, 0.04), np.zeros_like(x))))
    area = _beyond(m, rows, cols, out)
    npt.assert_allclose(area, 0.04 * (0.010 - 0.002), rtol=0.2)  # less the 2 mm its samples cover
    # contacts found beyond it later (another way round) cover what they touch
    y = np.linspace(-0.02, 0.02, 41)
    strip = np.column_stack((np.full_like(y, -0.007), y, np.full_like(y, 0.04)))
    m.samples = np.vstack((m.samples, strip))
    npt.assert_allclose(_beyond(m, rows, cols, out), area - 0.04 * 0.004, rtol=0.25)


def test_a_side_steepening_beyond_the_arms_reach_counts_only_up_to_the_tilt_limit():
    # a circle of 46 mm radius: 60° at the frontier, 5° short of the limit, turning 19° over the
    # last 10 mm: what lies beyond within the limit is 2.6 mm (walked from the frontier cells'
    # highest samples, their centres 1 mm further out)
    r = 0.04 / math.sin(math.radians(60))

    def rounded(x):
        tilt = np.arcsin((0.04 - x) / r)
        return r * np.cos(tilt) + 0.02, tilt

    m, rows, cols, out = _left_near_table(*_side(rounded))
    assert _beyond(m, rows, cols, out) < 0.04 * 0.003
    # a gentler curve (60 mm radius, 11.5° at the frontier, far from the limit): extrapolated only
    # as far as its turning was measured
    big = 0.06

    def gentle(x):
        tilt = np.arcsin((0.012 - x) / big)
        return big * np.cos(tilt) - 0.02, tilt

    m, rows, cols, out = _left_near_table(*_side(gentle))
    npt.assert_allclose(_beyond(m, rows, cols, out), 0.04 * (0.010 - 0.002), rtol=0.3)


def test_a_stall_at_the_rim_of_a_hollow_narrower_than_the_pad_is_a_valley_but_not_at_the_outer_rim():
    # a touched disc 60 mm across with an untouched hollow 12 mm across in it (a dent the flat pad
    # bridged); attempts stalled at the hollow's rim and at the disc's outer rim
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.06)
    pts, normals = disc(0.03, step=0.0005)
    hollow = np.linalg.norm(pts[:, :2] - (0.01, 0.0), axis=1) < 0.006
    m.add(pts[~hollow], normals[~hollow])
    valleys = m.valleys(0.08)
    assert valleys.any() and not m.valleys(0.008).any()  # 12 mm across: bridged by 80 mm, not by 8 mm
    assert np.all(np.linalg.norm(m.centre_of(*np.nonzero(valleys)) - (0.01, 0.0), axis=1) < 0.008)
    for angle in np.linspace(0.0, 2 * math.pi, 16, endpoint=False):
        d = (math.cos(angle), math.sin(angle))
        m.block((0.01, 0.0), 0.01, d, cause="stall")  # round the hollow
        m.block((0.03 * d[0], 0.03 * d[1]), 0.004, d, cause="stall")  # and on the outer rim
    rows, cols, out, reason = m.classify(math.radians(60), valley_m=0.08)
    near = np.linalg.norm(m.centre_of(rows, cols) - (0.01, 0.0), axis=1) < 0.01
    assert np.all((reason[near] == "valley") | (reason[near] == GAP)) and np.sum(reason[near] == "valley") > 10
    outer = np.linalg.norm(m.centre_of(rows, cols), axis=1) > 0.026
    assert np.any(reason[outer] == "stall") and not np.any(reason[outer] == "valley")
    # without the pad's width, nothing is a valley
    assert not np.any(m.classify(math.radians(60))[3] == "valley")


def _swaths(surface, gradient, gap):
    """A map of a surface ``z = surface(x, y)`` sampled every mm over 120 × 120 mm, with the
    outward normals of its ``gradient``, except where ``gap(x, y)``."""
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.1)
    x, y = (a.ravel() for a in np.meshgrid(np.arange(-0.06, 0.06, 0.001), np.arange(-0.06, 0.06, 0.001)))
    keep = ~gap(x, y)
    x, y = x[keep], y[keep]
    gx, gy = gradient(x, y)
    normals = np.column_stack((-gx, -gy, np.ones_like(x)))
    m.add(np.column_stack((x, y, surface(x, y))), normals / np.linalg.norm(normals, axis=1)[:, None])
    return m


def test_a_channel_the_pad_was_seen_to_bridge_is_a_valley_but_not_the_untouched_surroundings():
    # the floor of a concave groove (151 mm radius) left untouched along its whole length, open at
    # both ends: a gap, not a valley, until the pad is seen resting on both sides of it at once;
    # then the whole strip is one
    R = 0.151
    m = _swaths(lambda x, y: 0.05 + x**2 / (2 * R), lambda x, y: (x / R, 0 * y), lambda x, y: np.abs(x) < 0.015)
    assert not m.valleys(0.08).any()
    assert m.mark_bridged(np.array([-0.03, 0.0, 0.05]), np.array([0.03, 0.0, 0.05]), half_width_m=0.01) > 0
    xy = m.centre_of(*np.nonzero(m.valleys(0.08)))
    assert len(xy) > 0.8 * 15 * 60 and np.all(np.abs(xy[:, 0]) < 0.015)
    assert not m.valleys(0.02).any()  # 30 mm wide: a 20 mm pad does not bridge it
    # a bridge seen beyond the touched area (its contacts not recorded) explains nothing there
    m.mark_bridged(np.array([0.07, -0.03, 0.05]), np.array([0.07, 0.03, 0.05]), half_width_m=0.01)
    assert np.all(np.abs(m.centre_of(*np.nonzero(m.valleys(0.08)))[:, 0]) < 0.015)
    # touched later, it is no valley any more
    filled = np.array([[x, y, 0.05 + x**2 / (2 * R)] for x in np.arange(-0.016, 0.016, 0.001) for y in np.arange(-0.06, 0.06, 0.001)])
    m.add(filled, np.tile([0.0, 0.0, 1.0], (len(filled), 1)))
    assert not m.valleys(0.08).any()
    # contacts too close together mark nothing
    assert m.mark_bridged(np.zeros(3), np.array([0.008, 0.0, 0.0]), half_width_m=0.01) == 0


def test_a_pad_bridging_a_corner_of_a_hole_wider_than_itself_marks_no_channel():
    # a ring's hole wider than the pad (here square, 100 mm across, in a touched disc 200 mm
    # across): the pad rests on two rims across a corner of it; the closing by the pad's width
    # covers that corner, but the hole runs off nowhere, so it is no channel and no valley
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.12)
    x, y = (a.ravel() for a in np.meshgrid(np.arange(-0.1, 0.1, 0.001), np.arange(-0.1, 0.1, 0.001)))
    keep = (np.hypot(x, y) < 0.1) & ((np.abs(x) > 0.05) | (np.abs(y) > 0.05))
    pts = np.column_stack((x[keep], y[keep], np.full(keep.sum(), 0.05)))
    m.add(pts, np.tile([0.0, 0.0, 1.0], (len(pts), 1)))
    assert m.mark_bridged(np.array([-0.056, 0.03, 0.05]), np.array([-0.03, 0.056, 0.05]), half_width_m=0.01) > 0
    corner = m.cell_of(np.array([[-0.046, 0.046]]))[0]  # in the hole, by its corner
    assert m.hollow[corner[0], corner[1]]
    assert not m.valleys(0.08).any()


def test_the_rim_of_a_valley_seen_empty_is_a_hole_and_explained():
    # the dent of the test above, stalled round; a probe then finds it open down to the table
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.06)
    pts, normals = disc(0.03, step=0.0005)
    hollow = np.linalg.norm(pts[:, :2] - (0.01, 0.0), axis=1) < 0.006
    m.add(pts[~hollow], normals[~hollow])
    for angle in np.linspace(0.0, 2 * math.pi, 16, endpoint=False):
        m.block((0.01, 0.0), 0.01, (math.cos(angle), math.sin(angle)), cause="stall")
    m.mark_empty(m.centre_of(*np.nonzero(m.valleys(0.08))))
    assert not m.valleys(0.08).any()  # no surface left in it to count
    rows, cols, out, reason = m.classify(math.radians(60), valley_m=0.08)
    near = np.linalg.norm(m.centre_of(rows, cols) - (0.01, 0.0), axis=1) < 0.01
    assert np.all((reason[near] == HOLE) | (reason[near] == GAP)) and np.sum(reason[near] == HOLE) > 10
    assert HOLE in EXPLAINING
    outer = np.linalg.norm(m.centre_of(rows, cols), axis=1) > 0.026
    assert set(reason[outer]) <= {OPEN, GAP}  # the outer rim is no hole's


def test_across_the_band_a_probe_leaves_at_a_wide_hole_s_rim_the_stalls_face_the_hole():
    # a ring: its hole 90 mm across (wider than an 80 mm pad), stalled round its rim; a probe
    # found it open and marked it empty but for the 4 mm band along the rim
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.25)
    pts, normals = disc(0.09, step=0.001)
    radius = np.linalg.norm(pts[:, :2], axis=1)
    m.add(pts[radius >= 0.045], normals[radius >= 0.045])
    for angle in np.linspace(0.0, 2 * math.pi, 36, endpoint=False):
        d = np.array([math.cos(angle), math.sin(angle)])
        m.block(0.045 * d, 0.006, -d, cause="stall")
    hole = m.valleys(0.16, channels=False)
    assert hole.any() and not m.valleys(0.08).any()  # enclosed, too wide for the pad to bridge
    depth = ndimage.distance_transform_edt(hole) * m.cell_m
    inside = m.centre_of(*np.nonzero(hole & (depth > HOLE_RIM_M)))
    m.mark_empty(inside)  # seen empty by a border sweep, say: no probe's band
    assert not m.hole_rims().any()
    m.mark_empty(inside, opened=True)
    rims = m.hole_rims()
    rim_r = np.linalg.norm(m.centre_of(*np.nonzero(rims)), axis=1)
    assert np.all((rim_r > 0.045 - HOLE_RIM_M - 0.004) & (rim_r < 0.0455))  # the band, and only it
    npt.assert_allclose(np.count_nonzero(rims) * m.cell_m**2, 2 * math.pi * 0.043 * HOLE_RIM_M, rtol=0.35)
    # the band is the open hole's rim: a hollow to sweep where the estimate falls short, none
    # where unexplained frontier is left (what faces it is explained)
    assert m.valleys(0.16).any() and not m.valleys(0.16, open_rims=False).any()
    rows, cols, out, reason = m.classify(math.radians(60), valley_m=0.08)
    r = np.linalg.norm(m.centre_of(rows, cols), axis=1)
    inner = r < 0.05
    assert np.sum(reason[inner] == HOLE) > 0.9 * np.sum(reason[inner] != GAP)
    assert set(reason[r > 0.085]) <= {OPEN, GAP}  # the outer rim is no hole's
    # without the probe's finding the stalls stay what they were
    m.empty[:] = m.opened[:] = False
    _, _, _, before = m.classify(math.radians(60), valley_m=0.08)
    assert HOLE not in set(before)


def test_the_longest_run_counts_cells_connected_across_corners_but_not_across_a_gap():
    m = FrontierMap((0.0, 0.0), cell_m=0.002, extent_m=0.05)
    diagonal = (np.arange(10, 20), np.arange(10, 20))               # 10 cells, corner to corner
    apart = (np.full(4, 30), np.array([10, 11, 13, 14]))            # 2 + 2 cells, a cell missing
    rows, cols = np.concatenate((diagonal[0], apart[0])), np.concatenate((diagonal[1], apart[1]))
    assert m.longest_run_m(rows, cols) == pytest.approx(0.02)
    assert m.longest_run_m(*apart) == pytest.approx(0.004)
    assert m.longest_run_m(np.zeros(0, dtype=int), np.zeros(0, dtype=int)) == 0.0
